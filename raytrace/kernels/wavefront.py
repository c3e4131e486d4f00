"""The renderer's stages over waves of rays (Laine, Karras & Aila 2013,
"Megakernels Considered Harmful"; pbrt-v4's wavefront integrator).

A wave is a run of the image's TILE x TILE squares in a strip of TILE
rows, left to right (each square's rows, each pixel's camera samples).
waves.py runs each through:

1. ``camera_wave``: the wave's camera rays;
2. the structure's closest-hit kernel (kernels/cast.py), the one
   ``RayScene.cast_rays`` runs, each ray counting into its own row;
3. ``shade_wave``: each hit's frame, colour, ambient term and, for each
   light it faces, the light's share before visibility and its shadow rays;
4. the structure's any-hit kernel over those shadow rays (cast.py again);
5. ``light_wave``: each light's share times its visibility;
6. ``store_wave``: each pixel's samples summed into the image, its AOVs
   and, with AOVs, its rays' counters into its image row's.

Only steps 2 and 4 know the structure, so the shading compiles once for
every structure (its types hold no layout), and a structure compiles only
its two ray kernels.  The arithmetic is the megakernel's that this
replaced, term for term and in its order, so images and counters did not
change (docs/design.md, section 8).  Mirror and glass rays: bounces.py.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.buffers import MAT_AMBIENT, MAT_DIFFUSE, MAT_SHININESS, MAT_SPECULAR
from raytrace.kernels.cast import COLUMNS
from raytrace.kernels.counters import (
    BOX_TESTS,
    N_COUNTERS,
    OCCLUDED_RAYS,
    PRIM_TESTS,
    PRIMARY_RAYS,
    SHADING_POINTS,
    SHADOW_POINTS,
    SHADOW_RAYS,
)
from raytrace.kernels.jit import BLOCK, JIT, STAGE
from raytrace.kernels.packed import Packed, unpack
from raytrace.kernels.ray import Hit, ray_at
from raytrace.kernels.render import camera_ray, hit_frame, screen_point, sky, surface_albedo
from raytrace.kernels.sampling import hash_key, rand01, square_sample
from raytrace.kernels.shade import smooth_point

# What the shading stages read: a Render's fields without the structure
# and the textures, with the shadow mode as a number (NO_SHADOWS,
# HARD_SHADOWS, or soft shadows' sampling.PATTERN_*), so one compiled stage
# serves every mode.  The textures record goes apart, to the one stage
# that reads it (shade_wave): a textured scene's entry compiles that stage
# again and links the others as compiled for every scene.
Shading = namedtuple("Shading", ["geo", "lights", "shadow_mode", "seed", "cam", "background",
                                 "width", "height", "spp"])
NO_SHADOWS, HARD_SHADOWS = -2, -1
# A wave's camera rays: pixel (x, y), sample and film position (fx, fy) of
# each, the counter row it counts into (``counters``: its image row's, or with AOVs its own), the rays as
# cast.py takes them, their hits, the sample's colour and shading normal,
# and the range of its light entries in ShadowRays.
Wave = namedtuple("Wave", ["x", "y", "sample", "film", "row", "origins", "dirs", "t_min",
                           "t_max", "hit_t", "hit_prim", "hit_u", "hit_v", "cnt", "rgb",
                           "normal", "entries"])
# Shadow rays (each counting into its camera ray's row) and the light
# entries they answer: entry e is light light[e]'s share term[e] (before
# visibility) at one hit, seen through shadow rays first[e] .. first[e] +
# count[e] - 1 (none: always lit).
ShadowRays = namedtuple("ShadowRays", ["origins", "dirs", "t_min", "t_max", "row", "blocked",
                                       "light", "term", "first", "count"])

# Pixels go in TILE x TILE squares, a strip of TILE rows at a time: the
# rays of a square meet the same BVH nodes while they are in cache, which
# a 640-pixel row's do not.  8 was faster than 4 and 16 (docs/benchmarks.md,
# "Renderer").
TILE = 8
# Camera rays a wave holds at most, and shadow rays (and light entries)
# traced at once: enough that a call's fixed cost (tens of microseconds)
# is a small share of it, few enough that the buffers stay in the caches.
# A strip whose rays need more goes in several waves, a wave's hits in
# several shadow batches (soft shadows: 20M rays for the 640x480 teapot).
WAVE_RAYS = 8192
SHADOW_BATCH = 32768


def wave_squares(width, spp):
    """Squares a wave holds: WAVE_RAYS camera rays' worth, but no more than
    a strip of an image ``width`` pixels wide has, since a wave never spans
    two strips (a 64-pixel-wide render's buffers were 16 times what it used,
    allocated and filled for each render)."""
    return max(1, min(-(-width // TILE), WAVE_RAYS // (TILE * TILE * spp)))


@njit(**JIT)
def camera_wave(shading, wave, strip_top, y_end, cols, counters, row0, own_rows):
    """Camera rays of squares cols = (first, end) of the strip of TILE
    rows from strip_top (not past y_end), into wave; returns how many.
    Each counts into row y - row0 of counters, or with ``own_rows``
    (counters is wave.cnt: AOVs, where a pixel's tests are its cost) its
    own row."""
    width, spp, cam = shading.width, shading.spp, shading.cam
    k = 0
    for q in range(cols[0], cols[1]):
        x0 = q * TILE
        for y in range(strip_top, min(strip_top + TILE, y_end)):
            for x in range(x0, min(x0 + TILE, width)):
                for s in range(spp):
                    fx, fy = _film_point(shading, x, y, s)
                    ray, _, _ = camera_ray(cam, fx, fy)
                    wave.x[k], wave.y[k], wave.sample[k] = x, y, s
                    wave.film[k, 0], wave.film[k, 1] = fx, fy
                    wave.origins[k, 0], wave.origins[k, 1], wave.origins[k, 2] = ray.ox, ray.oy, ray.oz
                    wave.dirs[k, 0], wave.dirs[k, 1], wave.dirs[k, 2] = ray.dx, ray.dy, ray.dz
                    if own_rows:
                        wave.row[k] = k
                        counters[k, :] = 0
                    else:
                        wave.row[k] = y - row0
                    counters[wave.row[k], PRIMARY_RAYS] += 1
                    k += 1
    return k


# The film's hash salt, an int64: a Python int would be a literal, and
# hash_key compiled again for it.
_FILM_SALT = np.int64(0x5EED)


@njit(**JIT)
def _film_point(shading, x, y, s):
    """Film position (fx, fy) in [0,1]^2 of camera sample s of pixel (x,
    y): its centre, or with several samples a hashed point of the pixel
    (so tiles and threads never change it)."""
    width = shading.width
    if shading.spp == 1:
        jx, jy = 0.5, 0.5
    else:
        key = hash_key(shading.seed, y * width + x, s, _FILM_SALT)
        zero = np.int64(0)     # not literal 0s and 1s (sampling.square_sample)
        jx, jy = rand01(key, zero, zero), rand01(key, zero, np.int64(1))
    return (x + jx) / width, (y + jy) / shading.height


@njit(**JIT)
def _emit_shadow_rays(shading, li, origin, pixel, sample, rays, m):
    """Shadow rays from origin (a 3-tuple) to light li into rows m ... of
    rays (one to its centre, or its samples' pattern); returns how
    many."""
    mode, lights = shading.shadow_mode, shading.lights
    if mode == NO_SHADOWS:
        return 0
    if mode == HARD_SHADOWS:
        _shadow_ray(lights, li, 0.5, 0.5, origin, rays, m)
        return 1
    n, side = lights.samples[li], lights.side[li]
    key = hash_key(shading.seed, pixel, sample, li)
    col = row = np.int64(0)         # sample s's cell: (s % side, s // side)
    for s in range(n):
        if n == 1:
            su, sv = 0.5, 0.5
        else:
            su, sv = square_sample(mode, s, (col, row), side, key, lights.hashes)
        _shadow_ray(lights, li, su, sv, origin, rays, m + s)
        col += 1
        if col == side:
            col = np.int64(0)
            row += 1
    return n


@njit(**JIT)
def _shadow_ray(lights, li, su, sv, origin, rays, m):
    """Row m of rays: from origin to point (su, sv) of light li,
    unnormalised, so t in (0, 1) spans origin to light and nothing
    beyond it is tested."""
    ox, oy, oz = origin
    tx = lights.pos[li, 0] + (su - 0.5) * lights.u[li, 0] + (sv - 0.5) * lights.v[li, 0]
    ty = lights.pos[li, 1] + (su - 0.5) * lights.u[li, 1] + (sv - 0.5) * lights.v[li, 1]
    tz = lights.pos[li, 2] + (su - 0.5) * lights.u[li, 2] + (sv - 0.5) * lights.v[li, 2]
    rays.origins[m, 0], rays.origins[m, 1], rays.origins[m, 2] = ox, oy, oz
    rays.dirs[m, 0], rays.dirs[m, 1], rays.dirs[m, 2] = tx - ox, ty - oy, tz - oz


@njit(**STAGE)
def shade_wave(shading, textures, wave, k0, n, rays, counters):
    """Shade the hits of camera rays k0 .. while the shadow rays and light
    entries of one more hit fit in rays; returns (the first ray not
    shaded, shadow rays written).  A sample's colour starts as its ambient
    term (or the sky); light_wave adds the lights."""
    geo = shading.geo
    # int64, not the literal 0: a call with literal arguments is typed,
    # and compiled, as a variant of its own.
    e = m = np.int64(0)
    k = k0
    while k < n and room_for_hit(shading.lights, rays, e, m):
        wave.entries[k, 0] = e
        wave.entries[k, 1] = e
        prim = wave.hit_prim[k]
        if prim < 0:
            wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = sky(shading.background,
                                                                  wave.dirs[k, 1])
            k += 1
            continue
        # The ray camera_wave made, read back: made again, its square root
        # and divisions were a tenth of this stage's time.
        ray = ray_at(wave.origins, wave.dirs, wave.t_min, k)
        sxn, syn = screen_point(wave.film[k, 0], wave.film[k, 1])
        hit = Hit(wave.hit_t[k], prim, wave.hit_u[k], wave.hit_v[k])
        counters[wave.row[k], SHADING_POINTS] += 1
        f = hit_frame(geo, ray, hit)
        rgb = surface_albedo(textures, geo, shading.cam, hit, f.mat, f.px, f.py, f.pz, sxn, syn)
        wave.normal[k, 0], wave.normal[k, 1], wave.normal[k, 2] = f.nx, f.ny, f.nz
        pixel = wave.y[k] * shading.width + wave.x[k]
        r, g, b, e, m = light_entries(shading, hit, f, rgb, ray, (pixel, wave.sample[k]), rays,
                                      (e, m), counters, wave.row[k])
        wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = r, g, b
        wave.entries[k, 1] = e
        k += 1
    return k, m


@njit(**JIT)
def room_for_hit(lights, rays, e, m):
    """Whether the light entries and shadow rays of one more hit fit in
    rays, from entry e and shadow ray m on."""
    most_rays = 0
    for li in range(lights.pos.shape[0]):
        most_rays += max(lights.samples[li], 1)
    return e + lights.pos.shape[0] <= rays.light.shape[0] and m + most_rays <= rays.origins.shape[0]


@njit(**JIT)
def light_entries(shading, hit, f, rgb, ray, key, rays, em, counters, row):
    """Blinn-Phong up to each light's visibility, at frame
    f of ray's hit with the material's colour rgb, for the camera sample
    key = (pixel, sample): returns the ambient term (r, g, b) and, after
    the entries and shadow rays written from em = (entry, shadow ray) on,
    the next entry and shadow ray.  The rays count into counters[row]."""
    geo, lights = shading.geo, shading.lights
    e, m = em
    mat, ar, ag, ab = f.mat, rgb[0], rgb[1], rgb[2]
    kd = geo.mat_param[mat, MAT_DIFFUSE]
    ks = geo.mat_param[mat, MAT_SPECULAR]
    shin = geo.mat_param[mat, MAT_SHININESS]
    ka = geo.mat_param[mat, MAT_AMBIENT]
    px, py, pz, gx, gy, gz = f.px, f.py, f.pz, f.gx, f.gy, f.gz
    nx, ny, nz, eps = f.nx, f.ny, f.nz, f.eps
    sx, sy, sz = smooth_point(geo, hit, px, py, pz, f.side)
    lifted = (sx - px) * gx + (sy - py) * gy + (sz - pz) * gz > eps
    origin = (sx + eps * gx, sy + eps * gy, sz + eps * gz)
    for li in range(lights.pos.shape[0]):
        lx = lights.pos[li, 0] - px
        ly = lights.pos[li, 1] - py
        lz = lights.pos[li, 2] - pz
        dist = np.sqrt(lx * lx + ly * ly + lz * lz)
        lx, ly, lz = lx / dist, ly / dist, lz / dist
        ndl = nx * lx + ny * ly + nz * lz
        if ndl <= 0.0 or (gx * lx + gy * ly + gz * lz <= 0.0 and not lifted):
            continue
        spec = 0.0
        # Without a specular share (the ground's material) the term is 0
        # times a finite power (shininess >= 0), +0: its half vector and
        # libm's pow, a tenth of a render's time, are left out.
        if ks != 0.0:
            hx, hy, hz = lx - ray.dx, ly - ray.dy, lz - ray.dz
            hl = np.sqrt(hx * hx + hy * hy + hz * hz)
            if hl > 0.0:
                spec = ks * max(0.0, (nx * hx + ny * hy + nz * hz) / hl) ** shin
        rays.light[e] = li
        rays.term[e, 0] = kd * ar * ndl + spec
        rays.term[e, 1] = kd * ag * ndl + spec
        rays.term[e, 2] = kd * ab * ndl + spec
        rays.first[e] = m
        c = _emit_shadow_rays(shading, li, origin, key[0], key[1], rays, m)
        rays.count[e] = c
        if c:
            counters[row, SHADOW_POINTS] += 1
            counters[row, SHADOW_RAYS] += c
            for j in range(m, m + c):
                rays.row[j] = row
        m += c
        e += 1
    return ka * ar, ka * ag, ka * ab, e, m


@njit(**JIT)
def lit(shading, rays, entries, rgb, counters, row):
    """rgb (a 3-tuple: the ambient term) plus each light's share of
    entries = (first, end) times its visibility (the fraction of its shadow
    rays not blocked), added in the lights' order."""
    lights = shading.lights
    r, g, b = rgb
    for e in range(entries[0], entries[1]):
        li, c = rays.light[e], rays.count[e]
        vis = 1.0
        if c:
            free = 0
            for j in range(rays.first[e], rays.first[e] + c):
                free += not rays.blocked[j]
            counters[row, OCCLUDED_RAYS] += c - free
            vis = free / c
        lr, lg, lb = lights.color[li, 0], lights.color[li, 1], lights.color[li, 2]
        r += vis * lr * rays.term[e, 0]
        g += vis * lg * rays.term[e, 1]
        b += vis * lb * rays.term[e, 2]
    return r, g, b


@njit(**STAGE)
def light_wave(shading, wave, k0, k1, rays, counters):
    """Add the lights to the colours of camera rays k0 .. k1 - 1 (lit)."""
    for k in range(k0, k1):
        wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = lit(
            shading, rays, (wave.entries[k, 0], wave.entries[k, 1]),
            (wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2]), counters, wave.row[k])


@njit(**JIT)
def store_wave(shading, wave, n, band):
    """Each pixel's samples (consecutive camera rays) averaged into
    band.image and its first sample into the AOVs; with AOVs, each ray's
    counters (its own row) into its image row's, and its tests into the
    pixel's cost."""
    spp = shading.spp
    aovs = band.aovs
    with_aovs = aovs.depth.shape[0] != 0
    r = g = b = 0.0
    cost = 0
    for k in range(n):
        row, x, s = wave.y[k] - band.row0, wave.x[k], wave.sample[k]
        if s == 0:
            r = g = b = 0.0
            cost = 0
        r += wave.rgb[k, 0]
        g += wave.rgb[k, 1]
        b += wave.rgb[k, 2]
        if with_aovs:
            cnt = wave.cnt[k]
            stats = band.stats_rows[row]
            for col in range(N_COUNTERS):
                stats[col] += cnt[col]
            cost += cnt[BOX_TESTS] + cnt[PRIM_TESTS]
            if s == 0:
                _store_first_sample(wave, k, aovs, row, x)
        if s == spp - 1:
            band.image[row, x, 0] = r / spp
            band.image[row, x, 1] = g / spp
            band.image[row, x, 2] = b / spp
            if with_aovs:
                aovs.cost[row, x] = cost


@njit(**JIT)
def _store_first_sample(wave, k, aovs, row, x):
    """A pixel's first camera sample into the depth, primitive and normal
    AOVs (a miss: inf, -1 and 0)."""
    prim = wave.hit_prim[k]
    aovs.primid[row, x] = prim
    hit = prim >= 0
    aovs.depth[row, x] = wave.hit_t[k] if hit else np.inf
    for a in range(3):
        aovs.normal[row, x, a] = wave.normal[k, a] if hit else 0.0


# run_stage's steps.
CAMERA, SHADE, FINISH = 0, 1, 2


@njit(**BLOCK)
def run_stage(step, records, args):
    """One shading stage, for _Stages: one compiled entry for all of them
    (each entry's wrapper costs a share of a cold compile).  records:
    stage_records' (shading, textures, wave, rays, counters, band), packed
    (packed.py: their sixty-odd arrays unboxed one by one cost the
    wrapper 0.25 s more).  args: five ints.  CAMERA: camera_wave of the
    strip from row args[0] (rows below args[1]), squares args[2] ..
    args[3] - 1, counting into own rows if args[4]; returns (rays, 0).
    SHADE: shade_wave of rays args[0] .. args[1] - 1; returns (first ray
    not shaded, shadow rays).  FINISH: light_wave of rays args[0] ..
    args[1] - 1 and, when args[1] == args[2], store_wave of the wave's
    args[2] rays; returns (0, 0)."""
    shading, textures, wave, rays, counters, band = unpack(records)
    a, b, c, d, e = args
    if step == CAMERA:
        return camera_wave(shading, wave, a, b, (c, d), counters, band.row0, e != 0), 0
    if step == SHADE:
        return shade_wave(shading, textures, wave, a, b, rays, counters)
    light_wave(shading, wave, a, b, rays, counters)
    if b == c:
        store_wave(shading, wave, c, band)
    return 0, 0


def stage_records(shading, textures, wave, rays, counters, band):
    """run_stage's records, packed: made once for a thread's calls."""
    return Packed((shading, textures, wave, rays, counters, band))


def wave_buffers(rays):
    """A wave's arrays for ``rays`` camera rays; their interval, (0, inf),
    is filled here once, not by each wave."""
    f8, i8 = np.float64, np.int64
    return Wave(x=np.empty(rays, i8), y=np.empty(rays, i8), sample=np.empty(rays, i8),
                film=np.empty((rays, 2), f8), row=np.empty(rays, i8),
                origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                t_min=np.zeros(rays), t_max=np.full(rays, np.inf), hit_t=np.empty(rays, f8),
                hit_prim=np.empty(rays, i8), hit_u=np.empty(rays, f8), hit_v=np.empty(rays, f8),
                cnt=np.empty((rays, COLUMNS), i8), rgb=np.empty((rays, 3), f8),
                normal=np.empty((rays, 3), f8), entries=np.empty((rays, 2), i8))


def shadow_buffers(rays, entries):
    """Arrays for ``rays`` shadow rays and ``entries`` light entries; the
    rays' interval, (0, 1) (origin to light), is filled here once."""
    f8, i8 = np.float64, np.int64
    return ShadowRays(origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                      t_min=np.zeros(rays), t_max=np.ones(rays),
                      row=np.empty(rays, i8), blocked=np.empty(rays, np.bool_),
                      light=np.empty(entries, i8), term=np.empty((entries, 3), f8),
                      first=np.empty(entries, i8), count=np.empty(entries, i8))
