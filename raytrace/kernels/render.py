"""What a render is: its records, which the driver fills and the stages
read (waves.py, wavefront.py, bounces.py), and the pieces of shading every
stage shares: the camera ray, a hit's frame and colour, the sky.

What a render compiles is chosen by record types, so nothing else is
compiled: the structure's layout (only its ray kernels, query.py and
cast.py), textures (Textures, MeshTextures) and mirror and glass rays
(NoBounces, Bounces).  The shadow mode and AOVs are data: one compiled
stage serves them all.
"""
from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from raytrace.kernels.jit import JIT, OVERLOAD
from raytrace.kernels.ray import make_ray
from raytrace.kernels.shade import albedo, albedo_filtered, surface
from raytrace.kernels.texture import mesh_color

# Shadow modes: rays to each light's centre (``cast`` False: none, every
# light seen), or from samples of each area light (``pattern``:
# sampling.PATTERN_*); the stages read them as one number
# (wavefront.Shading.shadow_mode).
PointShadows = namedtuple("PointShadows", ["cast"])
SoftShadows = namedtuple("SoftShadows", ["pattern"])
# Per-pixel output buffers (raytrace/renderer/aov.py); empty (0 rows) when not
# asked for, so the same kernel serves renders with and without them.
Aovs = namedtuple("Aovs", ["depth", "normal", "primid", "cost"])
# Textures box-filtered over the camera sample's footprint (step_x, step_y:
# its extent in the pinhole's screen coordinates, sxn and syn in [-1, 1]),
# or with ``filtered`` False sampled at the hit point (aliasing shows); one
# kernel serves both, as they differ by a branch.
Textures = namedtuple("Textures", ["filtered", "step_x", "step_y"])
# The same, for a scene with vertex colours or image textures (bilinear
# when filtered, else the nearest texel): a type of its own, so other
# scenes never compile the lookups (kernels/texture.py).
MeshTextures = namedtuple("MeshTextures", Textures._fields)
# Mirror and glass rays followed to max_depth bounces, or none: a scene
# whose materials neither reflect nor transmit never compiles them.
NoBounces = namedtuple("NoBounces", [])
Bounces = namedtuple("Bounces", ["max_depth"])
# --integrator path (kernels/pathtrace.py) in place of either: paths of up
# to max_depth bounces, ``strategy`` (pathtrace.MIS, or one technique
# alone, for tests), Russian roulette from bounce ``roulette_depth`` on,
# and the emissive triangles (emit_tri) with their areas' running sum
# over the total (emit_cdf) and that total (emit_area; 0: none); its
# random numbers' ``sampler`` (pathtrace.INDEPENDENT or SOBOL).
Paths = namedtuple("Paths", ["max_depth", "strategy", "roulette_depth", "emit_tri", "emit_cdf",
                             "emit_area", "sampler"])
# The geometry, its structure, the lights, the shadow mode and the
# sampling seed.
Lighting = namedtuple("Lighting", ["geo", "acc", "lights", "shadows", "seed"])
# What every pixel of a render reads (cam: camera_buffer's 12 numbers).
Render = namedtuple("Render", ["lighting", "cam", "textures", "bounces", "background", "width",
                               "height", "spp"])
# Where a band of rows is written: image (rows, width, 3) float32 linear,
# the AOVs and the counter rows, each row y at y - row0.
Band = namedtuple("Band", ["image", "aovs", "stats_rows", "row0"])
# A hit's shading frame (hit_frame).
Frame = namedtuple("Frame", ["px", "py", "pz", "gx", "gy", "gz", "nx", "ny", "nz", "side", "mat",
                             "eps", "front"])

# Shadow rays start this far off the surface, relative to the magnitude of
# the hit point's coordinates.  The point is rebuilt from the primitive, so
# its error is a few float64 ulps of that magnitude (pbrt-v4 ch. 6.8 bounds
# it by gamma(7) ~ 7.8e-16).  Shadow rays re-hit their own surface at
# offsets up to 2^-52 and never from 2^-50 on, at scales 1e-4 to 1e4 and
# 1e5 from the origin (bench/ray_offset.py); 2^-44 keeps a factor 64 over
# that, and stays a negligible gap for a small scene far from the origin
# (docs/design.md, "Precision"; tests/test_self_intersection.py).
RAY_OFFSET = 2.0 ** -44


def triangle_albedo(textures, geo, hit, mat):
    """Colour of a triangle at its hit; compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(triangle_albedo, jit_options=OVERLOAD)
def _triangle_albedo(textures, geo, hit, mat):
    if textures.instance_class is MeshTextures:
        def impl(textures, geo, hit, mat):
            return mesh_color(geo, hit, mat, textures.filtered)
        return impl

    def impl(textures, geo, hit, mat):
        return geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    return impl


@njit(**JIT)
def surface_albedo(textures, geo, cam, hit, mat, px, py, pz, sxn, syn):
    """Surface colour at a hit of the camera ray through (sxn, syn)."""
    if hit.prim < geo.tri_v0.shape[0]:
        return triangle_albedo(textures, geo, hit, mat)
    if not textures.filtered:
        return albedo(geo, hit.prim, mat, px, py, pz)
    return albedo_filtered(geo, cam, hit.prim, mat, px, py, pz, sxn, syn, textures.step_x,
                           textures.step_y)


@njit(**JIT)
def point_albedo(textures, geo, hit, mat, px, py, pz):
    """Surface colour at a hit of a mirror or glass ray (no footprint)."""
    if hit.prim < geo.tri_v0.shape[0]:
        return triangle_albedo(textures, geo, hit, mat)
    return albedo(geo, hit.prim, mat, px, py, pz)


@njit(**JIT)
def sky(background, dy):
    """Background seen along a unit direction: a slight gradient with its
    elevation."""
    k = 0.8 + 0.2 * max(-1.0, min(1.0, dy))
    return background[0] * k, background[1] * k, background[2] * k


@njit(**JIT)
def hit_frame(geo, ray, hit):
    """The hit's point, normals faced towards the ray's origin (surfaces are
    two-sided), which side of the smooth surface that is (-1: its back),
    material, the offset secondary rays start at, and whether the ray meets
    the surface's front (a triangle's winding, a sphere's outside): a ray
    entering glass."""
    px, py, pz, gx, gy, gz, nx, ny, nz, mat, scale = surface(geo, ray, hit)
    front = not gx * ray.dx + gy * ray.dy + gz * ray.dz > 0.0
    if not front:
        gx, gy, gz = -gx, -gy, -gz
    side = 1.0
    if nx * gx + ny * gy + nz * gz < 0.0:
        nx, ny, nz = -nx, -ny, -nz
        side = -1.0
    eps = RAY_OFFSET * max(scale, abs(px), abs(py), abs(pz))
    return Frame(px, py, pz, gx, gy, gz, nx, ny, nz, side, mat, eps, front)


@njit(**JIT)
def screen_point(fx, fy):
    """Film position (fx, fy) in [0,1]^2 in the pinhole's screen
    coordinates (sxn, syn in [-1, 1], y up)."""
    return 2.0 * fx - 1.0, 1.0 - 2.0 * fy


@njit(**JIT)
def camera_ray(cam, fx, fy):
    """The camera ray through film position (fx, fy) in [0,1]^2, and that
    position in the pinhole's screen coordinates (sxn, syn in [-1, 1])."""
    # Pinhole camera: eye + forward + x * right + y * up (cam holds them
    # pre-scaled by the field of view and the aspect ratio).
    sxn, syn = screen_point(fx, fy)
    dx = cam[3] + sxn * cam[6] + syn * cam[9]
    dy = cam[4] + sxn * cam[7] + syn * cam[10]
    dz = cam[5] + sxn * cam[8] + syn * cam[11]
    ln = np.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx / ln, dy / ln, dz / ln
    # t_min given, as the ray kernels give it: an omitted one compiles
    # make_ray again.
    return make_ray(cam[0], cam[1], cam[2], dx, dy, dz, 0.0), sxn, syn


