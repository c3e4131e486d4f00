"""The render kernel: camera rays, shading, shadow rays.

``render_rows`` runs ``render_part`` on each thread (threads.py), which
does a part's rows.  What a render needs is chosen by the types of its
arguments, so each combination compiles on first use and nothing else is
compiled: the structure's layout (query.py), the shadow mode (PointShadows,
SoftShadows) and mirror and glass rays (NoBounces, Bounces).
AOV buffers are written when they have rows: a render with them and one
without share a kernel.
"""
import functools
from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from raytrace.kernels.buffers import (
    MAT_AMBIENT,
    MAT_DIFFUSE,
    MAT_IOR,
    MAT_REFLECT,
    MAT_SHININESS,
    MAT_SPECULAR,
    MAT_TRANSMIT,
)
from raytrace.kernels.counters import (
    BOX_TESTS,
    DEPTH_LIMITED,
    OCCLUDED_RAYS,
    PRIM_TESTS,
    PRIMARY_RAYS,
    REFLECTION_RAYS,
    REFRACTION_RAYS,
    SHADING_POINTS,
    SHADOW_POINTS,
    SHADOW_RAYS,
)
from raytrace.kernels.jit import BLOCK, JIT, OVERLOAD
from raytrace.kernels.limits import MAX_BOUNCES
from raytrace.kernels.lowlevel import frame_array, take_ticket
from raytrace.kernels.optics import bounce_weights, reflect, refract
from raytrace.kernels.query import closest_hit, occluded
from raytrace.kernels.ray import make_ray
from raytrace.kernels.sampling import hash_key, rand01, square_sample
from raytrace.kernels.shade import albedo, albedo_filtered, smooth_point, surface
from raytrace.kernels.texture import mesh_color
from raytrace.kernels.threads import run_on_threads

# Shadow modes: rays to each light's centre (``cast`` False: none, every light seen;
# one kernel for both, as they differ by a branch), or from samples of
# each area light (``pattern``: sampling.PATTERN_*).
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
# What a shading point's direct light reads: the geometry, its structure,
# the lights, the shadow mode and the sampling seed.  Its own record, so
# _direct compiles once for renders that differ only in textures, mirrors
# or glass.
Lighting = namedtuple("Lighting", ["geo", "acc", "lights", "shadows", "seed"])
# What every pixel of a render reads (cam: camera_buffer's 12 numbers).
Render = namedtuple("Render", ["lighting", "cam", "textures", "bounces", "background", "width",
                               "height", "spp"])
# Where a band of rows is written: image (rows, width, 3) float32 linear,
# the AOVs and the counter rows, each row y at y - row0.
Band = namedtuple("Band", ["image", "aovs", "stats_rows", "row0"])
# A hit's shading frame (_frame).
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


@njit(**JIT)
def _shadow_ray_blocked(geo, acc, lights, li, su, sv, ox, oy, oz, cnt):
    """Cast one shadow ray from (ox, oy, oz) to point (su, sv) of light li."""
    tx = lights.pos[li, 0] + (su - 0.5) * lights.u[li, 0] + (sv - 0.5) * lights.v[li, 0]
    ty = lights.pos[li, 1] + (su - 0.5) * lights.u[li, 1] + (sv - 0.5) * lights.v[li, 1]
    tz = lights.pos[li, 2] + (su - 0.5) * lights.u[li, 2] + (sv - 0.5) * lights.v[li, 2]
    # Unnormalised direction: t in (0, 1) spans origin to light, so nothing
    # beyond the light is ever tested.
    sray = make_ray(ox, oy, oz, tx - ox, ty - oy, tz - oz)
    cnt[SHADOW_RAYS] += 1
    if occluded(geo, acc, sray, 1.0, cnt):
        cnt[OCCLUDED_RAYS] += 1
        return True
    return False


@njit(**JIT)
def _hard_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
    cnt[SHADOW_POINTS] += 1
    return 0.0 if _shadow_ray_blocked(geo, acc, lights, li, 0.5, 0.5, ox, oy, oz, cnt) else 1.0


@njit(**JIT)
def _soft_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
    cnt[SHADOW_POINTS] += 1
    n = lights.samples[li]
    side = lights.side[li]
    key = hash_key(seed, pixel, sample, li)
    free = 0
    for s in range(n):
        if n == 1:
            su, sv = 0.5, 0.5
        else:
            su, sv = square_sample(shadows.pattern, s, n, side, key)
        if not _shadow_ray_blocked(geo, acc, lights, li, su, sv, ox, oy, oz, cnt):
            free += 1
    return free / n


def light_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
    """Fraction of light li seen from (ox, oy, oz); compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(light_visibility, jit_options=OVERLOAD)
def _light_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
    if shadows.instance_class is PointShadows:
        def impl(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
            if not shadows.cast:
                return 1.0
            return _hard_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel,
                                    sample, cnt)
        return impl

    def impl(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
        return _soft_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample,
                                cnt)
    return impl


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
def record_sample(aovs, y, x, t, prim, nx, ny, nz):
    """Write a pixel's first camera sample to the AOVs, if there are any."""
    if aovs.depth.shape[0] == 0:
        return
    aovs.depth[y, x] = t
    aovs.primid[y, x] = prim
    aovs.normal[y, x, 0] = nx
    aovs.normal[y, x, 1] = ny
    aovs.normal[y, x, 2] = nz


@njit(**JIT)
def record_cost(aovs, y, x, cost):
    """Write a pixel's box + primitive tests to the cost AOV, if there is one."""
    if aovs.cost.shape[0] != 0:
        aovs.cost[y, x] = cost


@njit(**JIT)
def _sky(background, dy):
    """Background seen along a unit direction: a slight gradient with its
    elevation."""
    k = 0.8 + 0.2 * max(-1.0, min(1.0, dy))
    return background[0] * k, background[1] * k, background[2] * k


@njit(**JIT)
def _frame(geo, ray, hit):
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
def _direct(lighting, hit, f, rgb, ray, pixel, sample, cnt):
    """Blinn-Phong at frame f of the ray's hit with the material's colour
    (rgb, a 3-tuple): ambient, then each light it faces, times the
    light's visibility (shadow rays)."""
    geo, acc, lights = lighting.geo, lighting.acc, lighting.lights
    mat, ar, ag, ab = f.mat, rgb[0], rgb[1], rgb[2]
    px, py, pz, gx, gy, gz = f.px, f.py, f.pz, f.gx, f.gy, f.gz
    nx, ny, nz, eps = f.nx, f.ny, f.nz, f.eps
    dx, dy, dz = ray.dx, ray.dy, ray.dz
    ka = geo.mat_param[mat, MAT_AMBIENT]
    kd = geo.mat_param[mat, MAT_DIFFUSE]
    ks = geo.mat_param[mat, MAT_SPECULAR]
    shin = geo.mat_param[mat, MAT_SHININESS]
    r, g, b = ka * ar, ka * ag, ka * ab
    # Shadow rays start from the smooth surface the vertex normals imply,
    # not the flat facet (Hanika 2021), then off it along the facet normal.
    sx, sy, sz = smooth_point(geo, hit, px, py, pz, f.side)
    lifted = (sx - px) * gx + (sy - py) * gy + (sz - pz) * gz > eps
    ox, oy, oz = sx + eps * gx, sy + eps * gy, sz + eps * gz
    for li in range(lights.pos.shape[0]):
        lx = lights.pos[li, 0] - px
        ly = lights.pos[li, 1] - py
        lz = lights.pos[li, 2] - pz
        dist = np.sqrt(lx * lx + ly * ly + lz * lz)
        lx, ly, lz = lx / dist, ly / dist, lz / dist
        # Lit where the shading normal faces the light.  Where the facet
        # itself faces away, a ray from a point on it could only hit the
        # facet; from a point lifted off it (a convex patch near the
        # terminator) the ray decides, as it would on the curved surface.
        # With flat normals, spheres and planes this is the facet's test.
        ndl = nx * lx + ny * ly + nz * lz
        if ndl <= 0.0 or (gx * lx + gy * ly + gz * lz <= 0.0 and not lifted):
            continue
        hx, hy, hz = lx - dx, ly - dy, lz - dz
        hl = np.sqrt(hx * hx + hy * hy + hz * hz)
        spec = 0.0
        if hl > 0.0:
            spec = ks * max(0.0, (nx * hx + ny * hy + nz * hz) / hl) ** shin
        vis = light_visibility(lighting.shadows, geo, acc, lights, li, ox, oy, oz, lighting.seed,
                               pixel, sample, cnt)
        lr, lg, lb = lights.color[li, 0], lights.color[li, 1], lights.color[li, 2]
        r += vis * lr * (kd * ar * ndl + spec)
        g += vis * lg * (kd * ag * ndl + spec)
        b += vis * lb * (kd * ab * ndl + spec)
    return r, g, b


@njit(**JIT)
def _camera_ray(cam, fx, fy):
    """The camera ray through film position (fx, fy) in [0,1]^2, and that
    position in the pinhole's screen coordinates (sxn, syn in [-1, 1])."""
    # Pinhole camera: eye + forward + x * right + y * up (cam holds them
    # pre-scaled by the field of view and the aspect ratio).
    sxn = 2.0 * fx - 1.0
    syn = 1.0 - 2.0 * fy
    dx = cam[3] + sxn * cam[6] + syn * cam[9]
    dy = cam[4] + sxn * cam[7] + syn * cam[10]
    dz = cam[5] + sxn * cam[8] + syn * cam[11]
    ln = np.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx / ln, dy / ln, dz / ln
    return make_ray(cam[0], cam[1], cam[2], dx, dy, dz), sxn, syn


def shade_sample(render, pixel, sample, fx, fy, cnt):
    """Colour of one camera ray through film position (fx, fy) in [0,1]^2:
    (r, g, b, t, prim, nx, ny, nz), the last five for the AOVs.  With
    NoBounces the surface's own shading; with Bounces mirror and glass
    rays too.  Compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(shade_sample, jit_options=OVERLOAD)
def _shade_sample(render, pixel, sample, fx, fy, cnt):
    if render.types[render.fields.index("bounces")].instance_class is NoBounces:
        def impl(render, pixel, sample, fx, fy, cnt):
            return _local_sample(render, pixel, sample, fx, fy, cnt)
        return impl

    def impl(render, pixel, sample, fx, fy, cnt):
        return _whitted_sample(render, pixel, sample, fx, fy, cnt)
    return impl


@njit(**JIT)
def _local_sample(render, pixel, sample, fx, fy, cnt):
    """A camera ray's hit shaded by its own material alone (shade_sample)."""
    lighting = render.lighting
    geo = lighting.geo
    ray, sxn, syn = _camera_ray(render.cam, fx, fy)
    cnt[PRIMARY_RAYS] += 1
    hit = closest_hit(geo, lighting.acc, ray, np.inf, cnt)
    if hit.prim < 0:
        r, g, b = _sky(render.background, ray.dy)
        return r, g, b, np.inf, -1, 0.0, 0.0, 0.0
    cnt[SHADING_POINTS] += 1
    f = _frame(geo, ray, hit)
    rgb = surface_albedo(render.textures, geo, render.cam, hit, f.mat, f.px, f.py, f.pz, sxn, syn)
    r, g, b = _direct(lighting, hit, f, rgb, ray, pixel, sample, cnt)
    return r, g, b, hit.t, hit.prim, f.nx, f.ny, f.nz


# Pending rays of a Whitted tree, depth first: at most one waiting sibling
# per level above the one being traced, and the two children of that one.
BOUNCE_STACK = MAX_BOUNCES + 2
_O, _D, _W, _DEPTH, _KIND, _ENTRY = 0, 3, 6, 9, 10, 11   # a pending ray's fields in the stack
_STACK_FLOATS = BOUNCE_STACK * _ENTRY           # a module constant: frame_array's size is literal
_CAMERA, _REFLECTED, _REFRACTED = 0.0, 1.0, 2.0   # a pending ray's kind


@njit(**JIT)
def _whitted_sample(render, pixel, sample, fx, fy, cnt):
    """Whitted (1980), for shade_sample: at each hit the material's own
    shading weighted by 1 - reflect - transmit, plus mirror and glass rays
    weighted by the material and Fresnel (Schlick) and tinted by its colour
    (white glass is clear), to max_depth bounces.  An explicit stack of
    pending rays (origin, direction, RGB weight, depth, kind) replaces
    recursion, which the kernels cannot have; the camera ray is its first
    entry, so the tracing and shading code is compiled once."""
    lighting, textures, cam = render.lighting, render.textures, render.cam
    geo = lighting.geo
    max_depth = render.bounces.max_depth
    ray0, sxn, syn = _camera_ray(cam, fx, fy)
    stack = frame_array(_STACK_FLOATS, np.float64)
    sp = _push(stack, 0, (ray0.ox, ray0.oy, ray0.oz), (ray0.dx, ray0.dy, ray0.dz), (1.0, 1.0, 1.0),
               0, _CAMERA)
    r = g = b = 0.0
    t0, prim0, n0x, n0y, n0z = np.inf, -1, 0.0, 0.0, 0.0
    while sp > 0:
        sp -= 1
        e = sp * _ENTRY
        ray = make_ray(stack[e + _O], stack[e + _O + 1], stack[e + _O + 2],
                       stack[e + _D], stack[e + _D + 1], stack[e + _D + 2])
        wr, wg, wb = stack[e + _W], stack[e + _W + 1], stack[e + _W + 2]
        depth = int(stack[e + _DEPTH])
        kind = stack[e + _KIND]
        cnt[PRIMARY_RAYS if kind == _CAMERA else
            REFLECTION_RAYS if kind == _REFLECTED else REFRACTION_RAYS] += 1
        hit = closest_hit(geo, lighting.acc, ray, np.inf, cnt)
        if hit.prim < 0:
            sr, sg, sb = _sky(render.background, ray.dy)
            r += wr * sr
            g += wg * sg
            b += wb * sb
            continue
        f = _frame(geo, ray, hit)
        px, py, pz, gx, gy, gz, nx, ny, nz = f.px, f.py, f.pz, f.gx, f.gy, f.gz, f.nx, f.ny, f.nz
        mat, eps = f.mat, f.eps
        if kind == _CAMERA:
            cnt[SHADING_POINTS] += 1
            t0, prim0, n0x, n0y, n0z = hit.t, hit.prim, nx, ny, nz
            rgb = surface_albedo(textures, geo, cam, hit, mat, px, py, pz, sxn, syn)
        else:
            rgb = point_albedo(textures, geo, hit, mat, px, py, pz)
        ar, ag, ab = rgb
        kr = geo.mat_param[mat, MAT_REFLECT]
        kt = geo.mat_param[mat, MAT_TRANSMIT]
        dx, dy, dz = ray.dx, ray.dy, ray.dz
        eta = 1.0
        if kt > 0.0:
            ior = geo.mat_param[mat, MAT_IOR]
            eta = 1.0 / ior if f.front else ior
        own, w_refl, w_refr = bounce_weights(kr, kt, -(dx * nx + dy * ny + dz * nz), eta)
        if own > 0.0:
            lr, lg, lb = _direct(lighting, hit, f, rgb, ray, pixel, sample, cnt)
            r += wr * own * lr
            g += wg * own * lg
            b += wb * own * lb
        if depth >= max_depth:
            # Counted, so the statistics explain the dark pixels the
            # missing light leaves (glass between glass surfaces).
            cnt[DEPTH_LIMITED] += (w_refl > 0.0) + (w_refr > 0.0)
            continue
        if w_refr > 0.0:
            ok, tx, ty, tz = refract(dx, dy, dz, nx, ny, nz, eta)
            if ok and tx * gx + ty * gy + tz * gz >= 0.0:
                # The shading normal bent the ray back out: bend it by the facet's.
                ok, tx, ty, tz = refract(dx, dy, dz, gx, gy, gz, eta)
            if ok:
                # Refracted rays start just inside the surface.
                sp = _push(stack, sp, (px - eps * gx, py - eps * gy, pz - eps * gz), (tx, ty, tz),
                           (wr * w_refr * ar, wg * w_refr * ag, wb * w_refr * ab), depth + 1,
                           _REFRACTED)
            else:
                w_refl += w_refr     # total internal reflection by the facet's normal
        if w_refl > 0.0:
            qx, qy, qz = reflect(dx, dy, dz, nx, ny, nz)
            if qx * gx + qy * gy + qz * gz <= 0.0:
                qx, qy, qz = reflect(dx, dy, dz, gx, gy, gz)
            sp = _push(stack, sp, (px + eps * gx, py + eps * gy, pz + eps * gz), (qx, qy, qz),
                       (wr * w_refl * ar, wg * w_refl * ag, wb * w_refl * ab), depth + 1,
                       _REFLECTED)
    return r, g, b, t0, prim0, n0x, n0y, n0z


@njit(**JIT)
def _push(stack, sp, origin, direction, weight, depth, kind):
    """Put a pending ray (origin, direction and RGB weight: 3-tuples) on the
    bounce stack; returns the new height."""
    e = sp * _ENTRY
    stack[e + _O], stack[e + _O + 1], stack[e + _O + 2] = origin
    stack[e + _D], stack[e + _D + 1], stack[e + _D + 2] = direction
    stack[e + _W], stack[e + _W + 1], stack[e + _W + 2] = weight
    stack[e + _DEPTH] = depth
    stack[e + _KIND] = kind
    return sp + 1


# Pixels go in TILE x TILE squares, a band of TILE rows at a time: the rays
# of a square meet the same BVH nodes while they are in L1, which a
# 640-pixel row's do not.  8 was faster than 4 and 16 (docs/benchmarks.md,
# "Renderer").
TILE = 8


@njit(**BLOCK)
def render_part(render, band, y0, y_end, clock):
    """Bands of TILE rows from y0 (band k: rows y0 + k TILE ...) below y_end
    into band, square by square, each band the next nobody has taken (a
    ticket from clock, as the query kernels take chunks: kernels/cast.py).
    Each row counts into its own band.stats_rows[y - band.row0]."""
    n_bands = (y_end - y0 + TILE - 1) // TILE
    width = render.width
    ticket = take_ticket(clock)
    while ticket < n_bands:
        top = y0 + ticket * TILE
        for x0 in range(0, width, TILE):
            for y in range(top, min(top + TILE, y_end)):
                _render_span(render, band, y, x0, min(x0 + TILE, width))
        ticket = take_ticket(clock)


@njit(**JIT)
def _render_span(render, band, y, x_first, x_end):
    """Pixels x_first .. x_end - 1 of row y."""
    width, height, spp = render.width, render.height, render.spp
    seed = render.lighting.seed
    row = y - band.row0
    cnt = band.stats_rows[row]
    image = band.image
    for x in range(x_first, x_end):
        pixel = y * width + x
        before = cnt[BOX_TESTS] + cnt[PRIM_TESTS]
        r = g = b = 0.0
        for s in range(spp):
            if spp == 1:
                jx, jy = 0.5, 0.5
            else:
                key = hash_key(seed, pixel, s, 0x5EED)
                jx, jy = rand01(key, 0, 0), rand01(key, 0, 1)
            sr, sg, sb, t, prim, nx, ny, nz = shade_sample(
                render, pixel, s, (x + jx) / width, (y + jy) / height, cnt)
            r += sr
            g += sg
            b += sb
            if s == 0:
                record_sample(band.aovs, row, x, t, prim, nx, ny, nz)
        image[row, x, 0] = r / spp
        image[row, x, 1] = g / spp
        image[row, x, 2] = b / spp
        record_cost(band.aovs, row, x, cnt[BOX_TESTS] + cnt[PRIM_TESTS] - before)


def render_rows(render, band, y0, y1, n_threads, clock):
    """Render rows y0 .. y1-1 of a Render into a Band: image row y is
    band.image[y - band.row0] (row0 = 0 for a whole-image buffer; a tile's
    own buffer starts at its first row), likewise its counter rows and
    AOVs.  clock: a one-element int64 array, 0 at the call.

    Each of n_threads parts (threads.py) takes the next band of TILE rows
    until none is left: the bottom of a picture (ground, with its shadow
    rays) costs more than the top (sky), and bands taken in turn by ticket
    keep the threads together (a fixed share each was slower whenever
    another process slowed one thread's core).
    """
    n_parts = max(1, min(n_threads, -(-(y1 - y0) // TILE)))
    run_on_threads([functools.partial(render_part, render, band, y0, y1, clock)] * n_parts)
