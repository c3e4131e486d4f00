"""The renderer as stages over waves of rays (Laine, Karras & Aila 2013,
"Megakernels Considered Harmful"; pbrt-v4's wavefront integrator).

A wave is a run of the image's TILE x TILE squares (render.py's order: a
strip of TILE rows at a time, its squares left to right, each square's
rows, each pixel's camera samples).  Each thread takes the next wave by
ticket and runs it through the stages:

1. ``camera_wave``: the wave's camera rays;
2. the structure's closest-hit kernel (kernels/cast.py), the one
   ``RayScene.cast_rays`` runs, with a counter row for each ray;
3. ``shade_wave``: each hit's frame, colour, ambient term and, for each
   light it faces, the light's share before visibility and its shadow rays;
4. the structure's any-hit kernel over those shadow rays (cast.py again);
5. ``light_wave``: each light's share times its visibility;
6. ``store_wave``: each pixel's samples summed into the image, its AOVs
   and its image row's counters.

Only steps 2 and 4 know the structure, so the shading compiles once for
every structure (its types hold no layout), and a structure compiles only
its two ray kernels, which the ray-casting API shares.  The arithmetic is
render.py's ``_local_sample`` term for term, in the same order, so the
images are the megakernel's bit for bit, and every counter keeps its
meaning: a ray's traversal counts go to its own row and from there to its
pixel's image row, as the megakernel counted them.

Mirror and glass rays (``Bounces``) still go through render.py's kernel.
"""
import functools
import threading
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.buffers import MAT_AMBIENT, MAT_DIFFUSE, MAT_SHININESS, MAT_SPECULAR
from raytrace.kernels.cast import COLUMNS, closest_rays, occluded_rays
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
from raytrace.kernels.jit import BLOCK, JIT
from raytrace.kernels.ray import Hit
from raytrace.kernels.render import (
    TILE,
    NoBounces,
    SoftShadows,
    _camera_ray,
    _frame,
    _sky,
    surface_albedo,
)
from raytrace.kernels.render import render_rows as megakernel_rows
from raytrace.kernels.sampling import hash_key, rand01, square_sample
from raytrace.kernels.shade import smooth_point
from raytrace.kernels.threads import run_on_threads

# What the shading stages read: a Render's fields without the structure,
# and the shadow mode as a number (NO_SHADOWS, HARD_SHADOWS, or soft
# shadows' sampling.PATTERN_*), so one compiled stage serves every mode.
Shading = namedtuple("Shading", ["geo", "lights", "shadow_mode", "seed", "cam", "textures",
                                 "background", "width", "height", "spp"])
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

# Camera rays a wave holds at most, and shadow rays (and light entries)
# traced at once: enough that a call's fixed cost is a small share of it,
# few enough that the buffers stay in the caches.  A strip whose rays need
# more goes in several waves, a wave's hits in several shadow batches.
WAVE_RAYS = 8192
SHADOW_BATCH = 8192


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
                    ray, _, _ = _camera_ray(cam, fx, fy)
                    wave.x[k], wave.y[k], wave.sample[k] = x, y, s
                    wave.film[k, 0], wave.film[k, 1] = fx, fy
                    wave.origins[k, 0], wave.origins[k, 1], wave.origins[k, 2] = ray.ox, ray.oy, ray.oz
                    wave.dirs[k, 0], wave.dirs[k, 1], wave.dirs[k, 2] = ray.dx, ray.dy, ray.dz
                    wave.t_min[k] = 0.0
                    wave.t_max[k] = np.inf
                    if own_rows:
                        wave.row[k] = k
                        counters[k, :] = 0
                    else:
                        wave.row[k] = y - row0
                    counters[wave.row[k], PRIMARY_RAYS] += 1
                    k += 1
    return k


@njit(**JIT)
def _film_point(shading, x, y, s):
    """Film position (fx, fy) in [0,1]^2 of camera sample s of pixel (x,
    y): its centre, or with several samples a hashed point of the pixel
    (render._render_span's)."""
    width = shading.width
    if shading.spp == 1:
        jx, jy = 0.5, 0.5
    else:
        key = hash_key(shading.seed, y * width + x, s, 0x5EED)
        jx, jy = rand01(key, 0, 0), rand01(key, 0, 1)
    return (x + jx) / width, (y + jy) / shading.height


@njit(**JIT)
def _emit_shadow_rays(shading, li, origin, pixel, sample, rays, m):
    """Shadow rays from origin (a 3-tuple) to light li into rows m ... of
    rays (render._hard_visibility's and _soft_visibility's); returns how
    many."""
    mode, lights = shading.shadow_mode, shading.lights
    if mode == NO_SHADOWS:
        return 0
    if mode == HARD_SHADOWS:
        _shadow_ray(lights, li, 0.5, 0.5, origin, rays, m)
        return 1
    n = lights.samples[li]
    key = hash_key(shading.seed, pixel, sample, li)
    for s in range(n):
        if n == 1:
            su, sv = 0.5, 0.5
        else:
            su, sv = square_sample(mode, s, n, lights.side[li], key)
        _shadow_ray(lights, li, su, sv, origin, rays, m + s)
    return n


@njit(**JIT)
def _shadow_ray(lights, li, su, sv, origin, rays, m):
    """Row m of rays: from origin to point (su, sv) of light li,
    unnormalised, so t in (0, 1) spans origin to light (render.py's
    _shadow_ray_blocked)."""
    ox, oy, oz = origin
    tx = lights.pos[li, 0] + (su - 0.5) * lights.u[li, 0] + (sv - 0.5) * lights.v[li, 0]
    ty = lights.pos[li, 1] + (su - 0.5) * lights.u[li, 1] + (sv - 0.5) * lights.v[li, 1]
    tz = lights.pos[li, 2] + (su - 0.5) * lights.u[li, 2] + (sv - 0.5) * lights.v[li, 2]
    rays.origins[m, 0], rays.origins[m, 1], rays.origins[m, 2] = ox, oy, oz
    rays.dirs[m, 0], rays.dirs[m, 1], rays.dirs[m, 2] = tx - ox, ty - oy, tz - oz
    rays.t_min[m] = 0.0
    rays.t_max[m] = 1.0


@njit(**JIT)
def shade_wave(shading, wave, k0, n, rays, counters):
    """Shade the hits of camera rays k0 .. while the shadow rays and light
    entries of one more hit fit in rays; returns (the first ray not
    shaded, shadow rays written).  A sample's colour starts as its ambient
    term (or the sky); light_wave adds the lights."""
    geo, lights = shading.geo, shading.lights
    n_lights = lights.pos.shape[0]
    most_rays = 0
    for li in range(n_lights):
        most_rays += max(lights.samples[li], 1)
    e = m = 0
    k = k0
    while k < n and e + n_lights <= rays.light.shape[0] and m + most_rays <= rays.origins.shape[0]:
        wave.entries[k, 0] = e
        wave.entries[k, 1] = e
        prim = wave.hit_prim[k]
        if prim < 0:
            wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = _sky(shading.background,
                                                                  wave.dirs[k, 1])
            k += 1
            continue
        pixel, s = wave.y[k] * shading.width + wave.x[k], wave.sample[k]
        ray, sxn, syn = _camera_ray(shading.cam, wave.film[k, 0], wave.film[k, 1])
        hit = Hit(wave.hit_t[k], prim, wave.hit_u[k], wave.hit_v[k])
        cnt = counters[wave.row[k]]
        cnt[SHADING_POINTS] += 1
        f = _frame(geo, ray, hit)
        ar, ag, ab = surface_albedo(shading.textures, geo, shading.cam, hit, f.mat, f.px, f.py,
                                    f.pz, sxn, syn)
        wave.normal[k, 0], wave.normal[k, 1], wave.normal[k, 2] = f.nx, f.ny, f.nz
        # render._direct up to each light's visibility, term for term.
        mat = f.mat
        ka = geo.mat_param[mat, MAT_AMBIENT]
        kd = geo.mat_param[mat, MAT_DIFFUSE]
        ks = geo.mat_param[mat, MAT_SPECULAR]
        shin = geo.mat_param[mat, MAT_SHININESS]
        wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = ka * ar, ka * ag, ka * ab
        px, py, pz, gx, gy, gz = f.px, f.py, f.pz, f.gx, f.gy, f.gz
        nx, ny, nz, eps = f.nx, f.ny, f.nz, f.eps
        sx, sy, sz = smooth_point(geo, hit, px, py, pz, f.side)
        lifted = (sx - px) * gx + (sy - py) * gy + (sz - pz) * gz > eps
        origin = (sx + eps * gx, sy + eps * gy, sz + eps * gz)
        for li in range(n_lights):
            lx = lights.pos[li, 0] - px
            ly = lights.pos[li, 1] - py
            lz = lights.pos[li, 2] - pz
            dist = np.sqrt(lx * lx + ly * ly + lz * lz)
            lx, ly, lz = lx / dist, ly / dist, lz / dist
            ndl = nx * lx + ny * ly + nz * lz
            if ndl <= 0.0 or (gx * lx + gy * ly + gz * lz <= 0.0 and not lifted):
                continue
            hx, hy, hz = lx - ray.dx, ly - ray.dy, lz - ray.dz
            hl = np.sqrt(hx * hx + hy * hy + hz * hz)
            spec = 0.0
            if hl > 0.0:
                spec = ks * max(0.0, (nx * hx + ny * hy + nz * hz) / hl) ** shin
            rays.light[e] = li
            rays.term[e, 0] = kd * ar * ndl + spec
            rays.term[e, 1] = kd * ag * ndl + spec
            rays.term[e, 2] = kd * ab * ndl + spec
            rays.first[e] = m
            c = _emit_shadow_rays(shading, li, origin, pixel, s, rays, m)
            rays.count[e] = c
            if c:
                cnt[SHADOW_POINTS] += 1
                cnt[SHADOW_RAYS] += c
                for j in range(m, m + c):
                    rays.row[j] = wave.row[k]
            m += c
            e += 1
        wave.entries[k, 1] = e
        k += 1
    return k, m


@njit(**JIT)
def light_wave(shading, wave, k0, k1, rays, counters):
    """Add each light's share times its visibility (the fraction of its
    shadow rays not blocked) to the colours of camera rays k0 .. k1 - 1,
    in render._direct's order."""
    lights = shading.lights
    for k in range(k0, k1):
        r, g, b = wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2]
        for e in range(wave.entries[k, 0], wave.entries[k, 1]):
            li, c = rays.light[e], rays.count[e]
            vis = 1.0
            if c:
                free = 0
                for j in range(rays.first[e], rays.first[e] + c):
                    free += not rays.blocked[j]
                counters[wave.row[k], OCCLUDED_RAYS] += c - free
                vis = free / c
            lr, lg, lb = lights.color[li, 0], lights.color[li, 1], lights.color[li, 2]
            r += vis * lr * rays.term[e, 0]
            g += vis * lg * rays.term[e, 1]
            b += vis * lb * rays.term[e, 2]
        wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = r, g, b


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
def run_stage(step, shading, wave, rays, counters, band, args):
    """One shading stage, for _Stages: one compiled entry for all of them
    (each entry's wrapper, unpacking these records, costs about a second
    of a cold compile).  args: five ints.  CAMERA: camera_wave of the
    strip from row args[0] (rows below args[1]), squares args[2] ..
    args[3] - 1, counting into own rows if args[4]; returns (rays, 0).
    SHADE: shade_wave of rays args[0] .. args[1] - 1; returns (first ray
    not shaded, shadow rays).  FINISH: light_wave of rays args[0] ..
    args[1] - 1 and, when args[1] == args[2], store_wave of the wave's
    args[2] rays; returns (0, 0)."""
    a, b, c, d, e = args
    if step == CAMERA:
        return camera_wave(shading, wave, a, b, (c, d), counters, band.row0, e != 0), 0
    if step == SHADE:
        return shade_wave(shading, wave, a, b, rays, counters)
    light_wave(shading, wave, a, b, rays, counters)
    if b == c:
        store_wave(shading, wave, c, band)
    return 0, 0


def _wave_buffers(rays):
    f8, i8 = np.float64, np.int64
    return Wave(x=np.empty(rays, i8), y=np.empty(rays, i8), sample=np.empty(rays, i8),
                film=np.empty((rays, 2), f8), row=np.empty(rays, i8),
                origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                t_min=np.empty(rays, f8), t_max=np.empty(rays, f8), hit_t=np.empty(rays, f8),
                hit_prim=np.empty(rays, i8), hit_u=np.empty(rays, f8), hit_v=np.empty(rays, f8),
                cnt=np.empty((rays, COLUMNS), i8), rgb=np.empty((rays, 3), f8),
                normal=np.empty((rays, 3), f8), entries=np.empty((rays, 2), i8))


def _shadow_buffers(rays, entries):
    f8, i8 = np.float64, np.int64
    return ShadowRays(origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                      t_min=np.empty(rays, f8), t_max=np.empty(rays, f8),
                      row=np.empty(rays, i8), blocked=np.empty(rays, np.bool_),
                      light=np.empty(entries, i8), term=np.empty((entries, 3), f8),
                      first=np.empty(entries, i8), count=np.empty(entries, i8))


class _Stages:
    """A thread's buffers and the stage calls of one wave."""

    def __init__(self, shading, acc, band):
        self.shading, self.acc, self.band = shading, acc, band
        spp = shading.spp
        self.squares = max(1, WAVE_RAYS // (TILE * TILE * spp))
        self.wave = _wave_buffers(self.squares * TILE * TILE * spp)
        samples = shading.lights.samples
        most = int(np.maximum(samples, 1).sum()) if len(samples) else 0
        self.rays = _shadow_buffers(max(SHADOW_BATCH, most), max(SHADOW_BATCH, len(samples)))
        # With AOVs each camera ray counts into a row of its own, summed
        # per pixel for the cost AOV; otherwise straight into its image row.
        self.counters = self.wave.cnt if len(band.aovs.cost) else band.stats_rows
        self.views = {}

    def strip(self, top, y_end):
        """The strip of TILE rows from ``top``, a wave of squares at a time."""
        n_cols = -(-self.shading.width // TILE)
        for q0 in range(0, n_cols, self.squares):
            self.trace(top, y_end, q0, min(q0 + self.squares, n_cols))

    def trace(self, top, y_end, q0, q1):
        shading, acc, wave, rays, counters = (self.shading, self.acc, self.wave, self.rays,
                                              self.counters)
        band, geo = self.band, shading.geo
        own = int(counters is wave.cnt)
        n, _ = run_stage(CAMERA, shading, wave, rays, counters, band, (top, y_end, q0, q1, own))
        camera_rays, hits = self._rays(n)
        closest_rays(geo, acc, camera_rays, hits, counters, wave.row[:n])
        k = 0
        while k < n:
            k1, m = run_stage(SHADE, shading, wave, rays, counters, band, (k, n, 0, 0, 0))
            if m:
                shadow_rays, blocked, rows = self._shadow_rays(m)
                occluded_rays(geo, acc, shadow_rays, blocked, counters, rows)
            run_stage(FINISH, shading, wave, rays, counters, band, (k, k1, n, 0, 0))
            k = k1

    def _rays(self, n):
        """The first n camera rays and hit rows, as the ray kernels take them
        (views made once for each length: most waves have the same)."""
        if n not in self.views:
            w = self.wave
            self.views[n] = ((w.origins[:n], w.dirs[:n], w.t_min[:n], w.t_max[:n]),
                             (w.hit_t[:n], w.hit_prim[:n], w.hit_u[:n], w.hit_v[:n]))
        return self.views[n]

    def _shadow_rays(self, m):
        r = self.rays
        return ((r.origins[:m], r.dirs[:m], r.t_min[:m], r.t_max[:m]), r.blocked[:m], r.row[:m])


def _strips(stages, y0, y_end, clock, lock):
    """One thread's share: strips of TILE rows taken by ticket until none is
    left, so a thread's counter rows are its own."""
    while True:
        with lock:
            ticket = int(clock[0])
            clock[0] += 1
        top = y0 + ticket * TILE
        if top >= y_end:
            return
        stages.strip(top, y_end)


def _load_stages(shading, acc, band):
    """Compile (or load) every stage, with empty buffers."""
    wave = _wave_buffers(0)
    rays = _shadow_buffers(0, 0)
    counters = band.stats_rows
    run_stage(CAMERA, shading, wave, rays, counters, band, (0, 0, 0, 0, 0))
    closest_rays(shading.geo, acc, (wave.origins, wave.dirs, wave.t_min, wave.t_max),
                 (wave.hit_t, wave.hit_prim, wave.hit_u, wave.hit_v), counters, wave.row)
    occluded_rays(shading.geo, acc, (rays.origins, rays.dirs, rays.t_min, rays.t_max),
                  rays.blocked, counters, rays.row)


def render_rows(render, band, y0, y1, n_threads, clock):
    """Render rows y0 .. y1-1 of a Render into a Band, as render.py's
    render_rows (which still renders mirrors and glass); y0 == y1 compiles
    or loads the kernels without rendering.  clock: a one-element int64
    array, 0 at the call: the strips' tickets."""
    if not isinstance(render.bounces, NoBounces):
        megakernel_rows(render, band, y0, y1, n_threads, clock)
        return
    lighting = render.lighting
    shadows = lighting.shadows
    mode = (shadows.pattern if isinstance(shadows, SoftShadows) else
            HARD_SHADOWS if shadows.cast else NO_SHADOWS)
    shading = Shading(lighting.geo, lighting.lights, mode, lighting.seed, render.cam,
                      render.textures, render.background, render.width, render.height, render.spp)
    if y1 <= y0:
        _load_stages(shading, lighting.acc, band)
        return
    n_parts = max(1, min(n_threads, -(-(y1 - y0) // TILE)))
    lock = threading.Lock()
    run_on_threads([functools.partial(_strips, _Stages(shading, lighting.acc, band), y0, y1,
                                      clock, lock) for _ in range(n_parts)])
