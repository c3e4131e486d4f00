"""The render kernel: camera rays, shading, shadow rays.

``render_rows`` is a thin parallel loop over thread parts; ``render_part``
does a part's rows.  What a render needs is chosen by the types of its
arguments, so each combination compiles on first use and nothing else is
compiled: the structure's layout (query.py), the shadow mode (NoShadows,
HardShadows, SoftShadows), the texture filter (PointTextures,
BoxFilteredTextures) and the AOV buffers (NoAovs, Aovs).
"""
from collections import namedtuple

import numpy as np
from numba import njit, prange
from numba.extending import overload

from ..buffers import MAT_AMBIENT, MAT_DIFFUSE, MAT_SHININESS, MAT_SPECULAR
from .counters import (
    BOX_TESTS,
    OCCLUDED_RAYS,
    PRIM_TESTS,
    PRIMARY_RAYS,
    SHADING_POINTS,
    SHADOW_POINTS,
    SHADOW_RAYS,
)
from .jit import JIT, OVERLOAD, PARALLEL
from .query import closest_hit, occluded
from .ray import make_ray
from .sampling import hash_key, rand01, square_sample
from .shade import albedo, albedo_filtered, smooth_point, surface

# Shadow modes: none casts no shadow rays; hard one ray per light, to its
# centre; soft samples each area light (``pattern``: sampling.PATTERN_*).
NoShadows = namedtuple("NoShadows", [])
HardShadows = namedtuple("HardShadows", [])
SoftShadows = namedtuple("SoftShadows", ["pattern"])
# Per-pixel output buffers (raytrace/aov.py), or none.
NoAovs = namedtuple("NoAovs", [])
Aovs = namedtuple("Aovs", ["depth", "normal", "primid", "cost"])
# Textures sampled at the hit point (aliasing shows), or box-filtered over
# the camera sample's footprint: step_x, step_y are its extent in the
# pinhole's screen coordinates (sxn, syn in [-1, 1]).
PointTextures = namedtuple("PointTextures", [])
BoxFilteredTextures = namedtuple("BoxFilteredTextures", ["step_x", "step_y"])

# Shadow rays start this far off the surface, relative to the magnitude of
# the hit point's coordinates.  The point is rebuilt from the primitive, so
# its error is a few float64 ulps of that magnitude (pbrt-v4 ch. 6.8 bounds
# it by gamma(7) ~ 7.8e-16).  Shadow rays re-hit their own surface at
# offsets up to 2^-52 and never from 2^-50 on, at scales 1e-4 to 1e4 and
# 1e5 from the origin (bench/ray_offset.py); 2^-44 keeps a factor 64 over
# that, and stays a negligible gap for a small scene far from the origin
# (docs/design.md, tests/test_self_intersection.py).
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
    cls = shadows.instance_class
    if cls is NoShadows:
        def impl(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
            return 1.0
        return impl
    visibility = _hard_visibility if cls is HardShadows else _soft_visibility

    def impl(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt):
        return visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt)
    return impl


def surface_albedo(textures, geo, cam, prim, mat, px, py, pz, sxn, syn):
    """Material colour at a hit of the camera ray through (sxn, syn);
    compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(surface_albedo, jit_options=OVERLOAD)
def _surface_albedo(textures, geo, cam, prim, mat, px, py, pz, sxn, syn):
    if textures.instance_class is PointTextures:
        def impl(textures, geo, cam, prim, mat, px, py, pz, sxn, syn):
            return albedo(geo, prim, mat, px, py, pz)
        return impl

    def impl(textures, geo, cam, prim, mat, px, py, pz, sxn, syn):
        return albedo_filtered(geo, cam, prim, mat, px, py, pz, sxn, syn,
                               textures.step_x, textures.step_y)
    return impl


def record_sample(aovs, y, x, t, prim, nx, ny, nz):
    """Write a pixel's first camera sample to the AOVs; compiled code only."""
    raise NotImplementedError("compiled code only")


def record_cost(aovs, y, x, cost):
    """Write a pixel's box + primitive tests to the cost AOV; compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(record_sample, jit_options=OVERLOAD)
def _record_sample(aovs, y, x, t, prim, nx, ny, nz):
    if aovs.instance_class is NoAovs:
        return lambda aovs, y, x, t, prim, nx, ny, nz: None

    def impl(aovs, y, x, t, prim, nx, ny, nz):
        aovs.depth[y, x] = t
        aovs.primid[y, x] = prim
        aovs.normal[y, x, 0] = nx
        aovs.normal[y, x, 1] = ny
        aovs.normal[y, x, 2] = nz
    return impl


@overload(record_cost, jit_options=OVERLOAD)
def _record_cost(aovs, y, x, cost):
    if aovs.instance_class is NoAovs:
        return lambda aovs, y, x, cost: None

    def impl(aovs, y, x, cost):
        aovs.cost[y, x] = cost
    return impl


@njit(**JIT)
def shade_sample(geo, acc, cam, lights, shadows, textures, background, seed, pixel, sample, fx, fy,
                 cnt):
    """Colour of one camera ray through film position (fx, fy) in [0,1]^2.

    Returns (r, g, b, t, prim, nx, ny, nz); the last five feed the AOVs.
    """
    # Pinhole camera: eye + forward + x * right + y * up (cam holds them
    # pre-scaled by the field of view and the aspect ratio).
    sxn = 2.0 * fx - 1.0
    syn = 1.0 - 2.0 * fy
    dx = cam[3] + sxn * cam[6] + syn * cam[9]
    dy = cam[4] + sxn * cam[7] + syn * cam[10]
    dz = cam[5] + sxn * cam[8] + syn * cam[11]
    ln = np.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx / ln, dy / ln, dz / ln
    ray = make_ray(cam[0], cam[1], cam[2], dx, dy, dz)
    cnt[PRIMARY_RAYS] += 1
    hit = closest_hit(geo, acc, ray, np.inf, cnt)
    if hit.prim < 0:
        # Sky: a slight gradient with the ray's elevation.
        k = 0.8 + 0.2 * max(-1.0, min(1.0, dy))
        return background[0] * k, background[1] * k, background[2] * k, np.inf, -1, 0.0, 0.0, 0.0
    cnt[SHADING_POINTS] += 1
    px, py, pz, gx, gy, gz, nx, ny, nz, mat, scale = surface(geo, ray, hit)
    # Face the normals towards the viewer (surfaces are two-sided).
    if gx * dx + gy * dy + gz * dz > 0.0:
        gx, gy, gz = -gx, -gy, -gz
    side = 1.0
    if nx * gx + ny * gy + nz * gz < 0.0:
        nx, ny, nz = -nx, -ny, -nz
        side = -1.0
    ar, ag, ab = surface_albedo(textures, geo, cam, hit.prim, mat, px, py, pz, sxn, syn)
    ka = geo.mat_param[mat, MAT_AMBIENT]
    kd = geo.mat_param[mat, MAT_DIFFUSE]
    ks = geo.mat_param[mat, MAT_SPECULAR]
    shin = geo.mat_param[mat, MAT_SHININESS]
    r, g, b = ka * ar, ka * ag, ka * ab
    eps = RAY_OFFSET * max(scale, abs(px), abs(py), abs(pz))
    # Shadow rays start from the smooth surface the vertex normals imply,
    # not the flat facet (Hanika 2021), then off it along the facet normal.
    sx, sy, sz = smooth_point(geo, hit, px, py, pz, side)
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
        vis = light_visibility(shadows, geo, acc, lights, li, ox, oy, oz, seed, pixel, sample, cnt)
        lr, lg, lb = lights.color[li, 0], lights.color[li, 1], lights.color[li, 2]
        r += vis * lr * (kd * ar * ndl + spec)
        g += vis * lg * (kd * ag * ndl + spec)
        b += vis * lb * (kd * ab * ndl + spec)
    return r, g, b, hit.t, hit.prim, nx, ny, nz


@njit(**JIT)
def render_part(geo, acc, cam, lights, shadows, textures, aovs, background, width, height,
                y_first, y_end, y_step, spp, seed, image, stats_rows):
    """Rows y_first, y_first + y_step, ... below y_end into image (height,
    width, 3) float32, linear.  Each row counts into its own stats_rows[y]."""
    for y in range(y_first, y_end, y_step):
        cnt = stats_rows[y]
        for x in range(width):
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
                    geo, acc, cam, lights, shadows, textures, background, seed, pixel, s,
                    (x + jx) / width, (y + jy) / height, cnt)
                r += sr
                g += sg
                b += sb
                if s == 0:
                    record_sample(aovs, y, x, t, prim, nx, ny, nz)
            image[y, x, 0] = r / spp
            image[y, x, 1] = g / spp
            image[y, x, 2] = b / spp
            record_cost(aovs, y, x, cnt[BOX_TESTS] + cnt[PRIM_TESTS] - before)


@njit(**PARALLEL)
def render_rows(geo, acc, cam, lights, shadows, textures, aovs, background, width, height,
                y0, y1, n_threads, spp, seed, image, stats_rows):
    """Render rows y0 .. y1-1.

    Part k of n_threads renders rows y0 + k, y0 + k + n_threads, ...:
    prange gives each thread one contiguous range, and the bottom of a
    picture (ground, with its shadow rays) costs more than the top (sky):
    contiguous halves of the hard-shadowed teapot split its ray-box and
    ray-primitive tests 43.5/56.5, interleaved rows 50.0/50.0.  (Numba's
    get_num_threads() inside the kernel would stop it being cached.)
    """
    n_parts = max(1, min(n_threads, y1 - y0))
    for k in prange(n_parts):
        render_part(geo, acc, cam, lights, shadows, textures, aovs, background, width, height,
                    y0 + k, y1, n_parts, spp, seed, image, stats_rows)
