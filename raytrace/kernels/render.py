"""The per-pixel render kernel: camera rays, shading, shadow rays."""
import numpy as np
from numba import njit, prange

from ..buffers import MAT_AMBIENT, MAT_DIFFUSE, MAT_SHININESS, MAT_SPECULAR
from .counters import (BOX_TESTS, OCCLUDED_RAYS, PRIM_TESTS, PRIMARY_RAYS,
                       SHADING_POINTS, SHADOW_POINTS, SHADOW_RAYS)
from .intersect import INLINE, KERNEL, make_ray
from .query import closest_hit, occluded
from .sampling import hash_key, rand01, square_sample
from .shade import albedo, surface

SHADOWS_NONE, SHADOWS_HARD, SHADOWS_SOFT = 0, 1, 2
SHADOW_MODES = {"none": SHADOWS_NONE, "hard": SHADOWS_HARD, "soft": SHADOWS_SOFT}

# Shadow rays start this far off the surface, relative to the magnitude of
# the hit point's coordinates.  The point is rebuilt from the primitive, so
# its error is a few float64 ulps of that magnitude (pbrt-v4 ch. 6.8 bounds
# it by gamma(7) ~ 7.8e-16).  Measured (bench/ray_offset.py): shadow rays
# re-hit their own sphere, triangle or plane at offsets up to 2^-52 (~2
# ulps), never from 2^-50 on, at scales 1e-4 to 1e4 and 1e5 from the
# origin; 2^-44 (~5.7e-14) keeps a factor 64 over that.  The offset is
# also a gap the shadow ray skips, so it must stay small against the
# scene: the former 2^-32 was 23% of a 1e-4 scene placed 1e5 from the
# origin, and let light through a slab 1% of the scene's size above the
# ground (tests/test_self_intersection.py).
RAY_OFFSET = 2.0 ** -44


@njit(**INLINE)
def shade_pixel_sample(geo, acc, cam, lights, background, shadow_mode, pattern, seed,
                       pixel, sample, fx, fy, cnt):
    """Colour of one camera ray through film position (fx, fy) in [0,1]^2.

    Returns (r, g, b, t, prim, nx, ny, nz) -- the extra fields feed the AOVs.
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
    t, prim, b1, b2 = closest_hit(geo, acc, ray, np.inf, cnt)
    if prim < 0:
        # Sky: a slight gradient with the ray's elevation.
        k = 0.8 + 0.2 * max(-1.0, min(1.0, dy))
        return background[0] * k, background[1] * k, background[2] * k, np.inf, -1, 0.0, 0.0, 0.0
    cnt[SHADING_POINTS] += 1
    px, py, pz, gx, gy, gz, nx, ny, nz, mat, scale = surface(geo, ray, t, prim, b1, b2)
    # Face the normals towards the viewer (surfaces are two-sided).
    if gx * dx + gy * dy + gz * dz > 0.0:
        gx, gy, gz = -gx, -gy, -gz
    if nx * gx + ny * gy + nz * gz < 0.0:
        nx, ny, nz = -nx, -ny, -nz
    ar, ag, ab = albedo(geo, prim, mat, px, py, pz)
    ka = geo.mat_param[mat, MAT_AMBIENT]
    kd = geo.mat_param[mat, MAT_DIFFUSE]
    ks = geo.mat_param[mat, MAT_SPECULAR]
    shin = geo.mat_param[mat, MAT_SHININESS]
    r, g, b = ka * ar, ka * ag, ka * ab
    eps = RAY_OFFSET * max(scale, abs(px), abs(py), abs(pz))
    ox, oy, oz = px + eps * gx, py + eps * gy, pz + eps * gz
    for li in range(lights.pos.shape[0]):
        lx = lights.pos[li, 0] - px
        ly = lights.pos[li, 1] - py
        lz = lights.pos[li, 2] - pz
        dist = np.sqrt(lx * lx + ly * ly + lz * lz)
        lx, ly, lz = lx / dist, ly / dist, lz / dist
        # Lit only from the side the geometric normal faces: this skips
        # shadow rays that could only hit the surface itself and avoids
        # light leaking past the shadow terminator of smooth normals.
        if gx * lx + gy * ly + gz * lz <= 0.0:
            continue
        ndl = max(0.0, nx * lx + ny * ly + nz * lz)
        hx, hy, hz = lx - dx, ly - dy, lz - dz
        hl = np.sqrt(hx * hx + hy * hy + hz * hz)
        spec = 0.0
        if hl > 0.0:
            spec = ks * max(0.0, (nx * hx + ny * hy + nz * hz) / hl) ** shin
        vis = 1.0
        if shadow_mode != SHADOWS_NONE:
            cnt[SHADOW_POINTS] += 1
            n = lights.samples[li]
            side = lights.side[li]
            key = hash_key(seed, pixel, sample, li)
            free = 0
            for s in range(n):
                if n == 1:
                    su, sv = 0.5, 0.5
                else:
                    su, sv = square_sample(pattern, s, n, side, key)
                tx = lights.pos[li, 0] + (su - 0.5) * lights.u[li, 0] + (sv - 0.5) * lights.v[li, 0]
                ty = lights.pos[li, 1] + (su - 0.5) * lights.u[li, 1] + (sv - 0.5) * lights.v[li, 1]
                tz = lights.pos[li, 2] + (su - 0.5) * lights.u[li, 2] + (sv - 0.5) * lights.v[li, 2]
                # Unnormalised direction: t in (0, 1) spans origin to light,
                # so nothing beyond the light is ever tested.
                sray = make_ray(ox, oy, oz, tx - ox, ty - oy, tz - oz)
                cnt[SHADOW_RAYS] += 1
                if occluded(geo, acc, sray, 1.0, cnt):
                    cnt[OCCLUDED_RAYS] += 1
                else:
                    free += 1
            vis = free / n
        lr, lg, lb = lights.color[li, 0], lights.color[li, 1], lights.color[li, 2]
        r += vis * lr * (kd * ar * ndl + spec)
        g += vis * lg * (kd * ag * ndl + spec)
        b += vis * lb * (kd * ab * ndl + spec)
    return r, g, b, t, prim, nx, ny, nz


@njit(**KERNEL)
def render_rows(geo, acc, cam, lights, background, width, height, y0, y1, n_threads, spp,
                shadow_mode, pattern, seed, image, stats_rows,
                aov_on, aov_depth, aov_normal, aov_prim, aov_cost):
    """Render rows y0 .. y1-1 into image (height, width, 3) float32, linear.

    Each row counts into its own stats_rows[y], so threads never share a
    counter.  With aov_on the depth, normal, primitive id and per-pixel cost
    (box + primitive tests) of the pixel are written too.

    Part k of n_threads renders rows y0 + k, y0 + k + n_threads, ...:
    prange gives each thread one contiguous range, and the bottom of a
    picture (ground, with its shadow rays) costs more than the top (sky):
    contiguous halves of the hard-shadowed teapot split its ray-box and
    ray-primitive tests 43.5/56.5, interleaved rows 50.0/50.0.  (Numba's
    get_num_threads() inside the kernel would stop it being cached.)
    """
    n_parts = max(1, min(n_threads, y1 - y0))
    for k in prange(n_parts):
        for y in range(y0 + k, y1, n_parts):
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
                    sr, sg, sb, t, prim, nx, ny, nz = shade_pixel_sample(
                        geo, acc, cam, lights, background, shadow_mode, pattern, seed,
                        pixel, s, (x + jx) / width, (y + jy) / height, cnt)
                    r += sr
                    g += sg
                    b += sb
                    if aov_on and s == 0:
                        aov_depth[y, x] = t
                        aov_prim[y, x] = prim
                        aov_normal[y, x, 0] = nx
                        aov_normal[y, x, 1] = ny
                        aov_normal[y, x, 2] = nz
                image[y, x, 0] = r / spp
                image[y, x, 1] = g / spp
                image[y, x, 2] = b / spp
                if aov_on:
                    aov_cost[y, x] = cnt[BOX_TESTS] + cnt[PRIM_TESTS] - before
