"""A path tracer on the wavefront stages (``--integrator path``).

The rendering equation estimated by paths (Kajiya 1986), traced a
generation of rays at a time as bounces.py traces mirrors and glass: a
wave's camera rays are generation 0, and each hit spawns at most one ray
of the next generation, through the structure's closest-hit and any-hit
kernels (kernels/cast.py), like every other ray.

At each hit: the emitted radiance of an emissive surface's front; then one
event chosen with the material's shares (optics.bounce_weights): the
mirror or glass ray (a specular event, tinted by the colour as in
Whitted's), or the Lambertian lobe (albedo ``diffuse`` x colour), for
which the light is estimated twice and combined by multiple importance
sampling (Veach & Guibas 1995; Veach 1997 ch. 9, the power heuristic,
beta = 2): next-event estimation (one shadow ray to a point on each point
or area light, and one to a point on an emissive triangle chosen by area)
and the cosine-sampled bounce ray (Malley's method), whose weight is
applied when it meets an emitter.  After ``roulette_depth`` bounces a path
goes on with probability min(0.95, its throughput's largest component)
(Russian roulette, Arvo & Kirk 1990), its throughput divided by it.

The point and area lights keep their Whitted meaning: a light of colour c
adds albedo x c x cos to the surface facing it, without fall-off (they are
not geometry and no bounce ray meets them), so a path of depth 1 lights a
diffuse surface as the whitted image's diffuse term does.

Random numbers are hashes of (seed, pixel, sample, path dimension)
(sampling.py): each sample's path is the same whatever the tile, thread or
structure; a sample's contributions are added in one order (its vertices
in turn: emission, then its light samples), so the image is too.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.buffers import (
    MAT_DIFFUSE,
    MAT_EMISSION,
    MAT_GLOSSY,
    MAT_IOR,
    MAT_REFLECT,
    MAT_SHININESS,
    MAT_TRANSMIT,
)
from raytrace.kernels.counters import (
    BOUNCE_RAYS,
    EMITTER_SAMPLES,
    OCCLUDED_RAYS,
    ROULETTE_ENDED,
    SHADING_POINTS,
    SHADOW_POINTS,
    SHADOW_RAYS,
)
from raytrace.kernels.glossy import lobe_value, phong_direction
from raytrace.kernels.jit import BLOCK, JIT, STAGE
from raytrace.kernels.optics import bounce_weights, reflect, refract
from raytrace.kernels.packed import Packed, unpack
from raytrace.kernels.ray import Hit, make_ray
from raytrace.kernels.render import (
    camera_ray,
    hit_frame,
    point_albedo,
    screen_point,
    sky,
    surface_albedo,
)
from raytrace.kernels.sampling import hash_key, rand01
from raytrace.kernels.shade import smooth_point
from raytrace.kernels.sobol import sobol_pair01
from raytrace.kernels.wavefront import CAMERA, camera_wave, store_wave

# Paths.strategy: both techniques weighted by MIS, or one alone (tests:
# each is unbiased, so all three agree in the mean).
MIS, BSDF_ONLY, LIGHTS_ONLY = 0, 1, 2
# Paths.sampler: a path's numbers hashed independently, or Owen-scrambled
# Sobol points (kernels/sobol.py), a pair of dimensions at a time.
INDEPENDENT, SOBOL = 0, 1
SAMPLERS = {"independent": INDEPENDENT, "sobol": SOBOL}
# Bounces before Russian roulette may end a path, and the most a path is
# kept with (a path of white walls is not kept forever).
ROULETTE_DEPTH = 3
ROULETTE_MAX = 0.95
# A shadow ray to a point on an emitter ends this fraction short of it, so
# the emitter itself is no occluder.
EMITTER_GAP = 2.0 ** -20
# The third key of a path's random numbers (its camera sample's are 0x5EED).
# int64s, as every constant passed to a compiled helper: a Python int would
# be a literal, and the helper compiled again for it.
_PATH_SALT = np.int64(0x9A7)
# The Sobol sampler's per-pixel key, and its pair for the film point.
_SOBOL_SALT = np.int64(0x50B01)
_FILM_PAIR = np.int64(0x7FFFFFFF)
_INV_PI = 1.0 / np.pi

# A generation of paths: rays as cast.py takes them, their hits, the
# camera sample each serves (its index in the wave) and counts for, its
# depth, throughput and the solid-angle density its direction was drawn
# with (0: a camera ray or a specular event, whose emitter hits take no
# MIS weight).
PathRays = namedtuple("PathRays", ["origins", "dirs", "t_min", "t_max", "hit_t", "hit_prim",
                                   "hit_u", "hit_v", "sample", "row", "depth", "weight", "pdf"])
# Shadow rays of next-event estimation, each with its camera sample and the
# light it adds if nothing blocks it.
LightRays = namedtuple("LightRays", ["origins", "dirs", "t_min", "t_max", "row", "blocked",
                                     "sample", "rgb"])

# The path stages' steps, after wavefront.CAMERA (SHADE: run_path_shade).
SHADE, FINISH, STORE = 1, 2, 3


@njit(**JIT)
def power_heuristic(pa, pb):
    """Veach's power heuristic (beta = 2): technique a's weight."""
    a2, b2 = pa * pa, pb * pb
    return a2 / (a2 + b2) if a2 > 0.0 else 0.0


@njit(**JIT)
def path_pair(paths, rng, i):
    """A path's numbers of dimensions (i, 0) and (i, 1), in [0, 1); rng =
    (its sample's hash key, its pixel's key, the sample's index).
    Independent: hashes of the key; Sobol: the pixel's shuffled, scrambled
    2-D Sobol point number ``sample`` of pair i."""
    if paths.sampler == SOBOL:
        return sobol_pair01(rng[1], rng[2], i)
    return rand01(rng[0], i, np.int64(0)), rand01(rng[0], i, np.int64(1))    # not literals


@njit(**JIT)
def path_rand(paths, rng, i, dim):
    """The one number of dimension (i, dim) (path_pair's)."""
    if paths.sampler == SOBOL:
        return sobol_pair01(rng[1], rng[2], i)[dim]
    return rand01(rng[0], i, dim)


@njit(**JIT)
def emitter_pdf(paths, cos_l, dist2):
    """The solid-angle density of the area-weighted emitter sample at a
    point dist2 (squared) away, seen at cos_l from its normal."""
    return dist2 / (cos_l * paths.emit_area)


@njit(**JIT)
def pick_emitter(paths, u):
    """The index in emit_tri of the emissive triangle whose share of the
    total area holds u (binary search of the running sum)."""
    lo, hi = 0, paths.emit_cdf.shape[0] - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if paths.emit_cdf[mid] <= u:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(**JIT)
def emitter_numbers(paths, rng, dim):
    """The emitter sample's triangle (its index in emit_tri) and the two
    numbers of its point.  Independent: three dimensions, as the first
    slice drew them.  Sobol: one pair; its first number picks the
    triangle and, rescaled within the triangle's share, serves again
    (pbrt's remapped discrete sample), so the pair's stratification covers
    the emitters' whole area."""
    u, v = path_pair(paths, rng, dim + 1)
    j = pick_emitter(paths, u)
    if paths.sampler != SOBOL:
        return j, v, path_rand(paths, rng, dim, np.int64(1))
    lo = paths.emit_cdf[j - 1] if j > 0 else 0.0
    share = paths.emit_cdf[j] - lo
    r = min(max((u - lo) / share, 0.0), 1.0 - 2.0 ** -53) if share > 0.0 else 0.5
    return j, r, v


@njit(**JIT)
def _light_ray(shadow, m, origin, target, gap, entry):
    """Row m of shadow: from origin towards target, ending ``gap`` short of
    it; entry = (camera sample, row, rgb)."""
    for a in range(3):
        shadow.origins[m, a] = origin[a]
        shadow.dirs[m, a] = target[a] - origin[a]
        shadow.rgb[m, a] = entry[2][a]
    shadow.t_max[m] = 1.0 - gap
    shadow.sample[m] = entry[0]
    shadow.row[m] = entry[1]
    return m + 1


@njit(**JIT)
def next_event(shading, paths, f, origin, frame, shadow, m, counters):
    """Shadow rays from ``origin`` (the lifted shading point) to one point
    of each light and of one emissive triangle, for the surface's lobe at
    frame f; frame = ((random key, first dimension, whether origin is
    lifted above the flat surface), lobe, throughput, camera sample, row),
    the lobe as glossy.lobe_value takes it: with no glossy weight, the
    Lambertian lobe of reflectance lobe[0] (an RGB tuple) alone.
    Returns the next free row of shadow."""
    geo, lights = shading.geo, shading.lights
    (rng, dim, lifted), lobe, thr, k, row = frame
    alb, glossy = lobe[0], lobe[1] > 0.0
    nx, ny, nz, gx, gy, gz = f.nx, f.ny, f.nz, f.gx, f.gy, f.gz
    for li in range(lights.pos.shape[0]):
        su, sv = path_pair(paths, rng, dim + 2 + li)
        tx = lights.pos[li, 0] + (su - 0.5) * lights.u[li, 0] + (sv - 0.5) * lights.v[li, 0]
        ty = lights.pos[li, 1] + (su - 0.5) * lights.u[li, 1] + (sv - 0.5) * lights.v[li, 1]
        tz = lights.pos[li, 2] + (su - 0.5) * lights.u[li, 2] + (sv - 0.5) * lights.v[li, 2]
        lx, ly, lz = tx - f.px, ty - f.py, tz - f.pz
        dist = np.sqrt(lx * lx + ly * ly + lz * lz)
        lx, ly, lz = lx / dist, ly / dist, lz / dist
        ndl = nx * lx + ny * ly + nz * lz
        if ndl <= 0.0 or (gx * lx + gy * ly + gz * lz <= 0.0 and not lifted):
            continue
        rgb = (thr[0] * alb[0] * ndl * lights.color[li, 0],
               thr[1] * alb[1] * ndl * lights.color[li, 1],
               thr[2] * alb[2] * ndl * lights.color[li, 2])
        if glossy:      # pi f cos: for the Lambertian lobe, albedo x cos as above
            fc, _ = lobe_value(lobe, nx, ny, nz, lx, ly, lz)
            rgb = (np.pi * thr[0] * fc[0] * lights.color[li, 0],
                   np.pi * thr[1] * fc[1] * lights.color[li, 1],
                   np.pi * thr[2] * fc[2] * lights.color[li, 2])
        m = _light_ray(shadow, m, origin, (tx, ty, tz), 0.0, (k, row, rgb))
        counters[row, SHADOW_POINTS] += 1
        counters[row, SHADOW_RAYS] += 1
    if paths.emit_area <= 0.0 or paths.strategy == BSDF_ONLY:
        return m
    counters[row, EMITTER_SAMPLES] += 1
    j, r1, r2 = emitter_numbers(paths, rng, dim)
    t = paths.emit_tri[j]
    # A uniform point of the triangle (Osada et al. 2002's square-root map).
    r1 = np.sqrt(r1)
    b0, b1 = 1.0 - r1, r2 * r1
    b2 = 1.0 - b0 - b1
    v0, v1, v2 = geo.tri_v0, geo.tri_v1, geo.tri_v2
    y = (b0 * v0[t, 0] + b1 * v1[t, 0] + b2 * v2[t, 0], b0 * v0[t, 1] + b1 * v1[t, 1] + b2 * v2[t, 1],
         b0 * v0[t, 2] + b1 * v1[t, 2] + b2 * v2[t, 2])
    ex, ey, ez = v1[t, 0] - v0[t, 0], v1[t, 1] - v0[t, 1], v1[t, 2] - v0[t, 2]
    fx, fy, fz = v2[t, 0] - v0[t, 0], v2[t, 1] - v0[t, 1], v2[t, 2] - v0[t, 2]
    cx, cy, cz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
    cl = np.sqrt(cx * cx + cy * cy + cz * cz)
    # From the shadow ray's origin, where bounce rays start too: the
    # emitter's density is then the one emitted() weighs a bounce ray's
    # hit with, and the two weights sum to one.
    lx, ly, lz = y[0] - origin[0], y[1] - origin[1], y[2] - origin[2]
    dist2 = lx * lx + ly * ly + lz * lz
    dist = np.sqrt(dist2)
    lx, ly, lz = lx / dist, ly / dist, lz / dist
    cos_l = -(cx * lx + cy * ly + cz * lz) / cl      # the emitter's front faces the point
    ndl = nx * lx + ny * ly + nz * lz
    if cos_l <= 0.0 or ndl <= 0.0 or (gx * lx + gy * ly + gz * lz <= 0.0 and not lifted):
        return m
    pdf_l = emitter_pdf(paths, cos_l, dist2)
    if glossy:
        fc, pdf_b = lobe_value(lobe, nx, ny, nz, lx, ly, lz)
    else:
        fc, pdf_b = (alb[0], alb[1], alb[2]), ndl * _INV_PI
    w = 1.0 if paths.strategy == LIGHTS_ONLY else power_heuristic(pdf_l, pdf_b)
    # Lambertian alone: albedo x (cos / pi), as the first slice computed it.
    s = w / pdf_l if glossy else w * ndl * _INV_PI / pdf_l
    mat = geo.tri_mat[t]
    e = geo.mat_param[mat]
    rgb = (thr[0] * fc[0] * e[MAT_EMISSION] * s, thr[1] * fc[1] * e[MAT_EMISSION + 1] * s,
           thr[2] * fc[2] * e[MAT_EMISSION + 2] * s)
    counters[row, SHADOW_POINTS] += 1
    counters[row, SHADOW_RAYS] += 1
    return _light_ray(shadow, m, origin, y, EMITTER_GAP, (k, row, rgb))


@njit(**JIT)
def emitted(paths, geo, f, hit, pdf, ray):
    """The MIS weight of an emitter met by ``ray`` (unit direction) at
    ``hit``, its direction drawn with density pdf (0: no MIS): 1 where no
    light sample could have found it (a camera ray, a specular event, a
    sphere or a plane), else the power heuristic against the emitter
    sample's density there (0 with light samples alone)."""
    if pdf <= 0.0 or hit.prim >= geo.tri_v0.shape[0] or paths.strategy == BSDF_ONLY:
        return 1.0
    if paths.strategy == LIGHTS_ONLY:
        return 0.0
    cos_l = abs(f.gx * ray.dx + f.gy * ray.dy + f.gz * ray.dz)
    return power_heuristic(pdf, emitter_pdf(paths, cos_l, hit.t * hit.t))


@njit(**JIT)
def cosine_direction(nx, ny, nz, u1, u2):
    """A direction about unit n with density cos / pi (Malley's method: a
    uniform point of the disc lifted to the hemisphere), in the
    orthonormal basis of Duff et al. 2017; returns it and its cosine."""
    sign = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    tx, ty, tz = 1.0 + sign * nx * nx * a, sign * b, -sign * nx
    bx, by, bz = b, sign + ny * ny * a, -ny
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    x, y, z = r * np.cos(phi), r * np.sin(phi), np.sqrt(max(0.0, 1.0 - u1))
    return (x * tx + y * bx + z * nx, x * ty + y * by + z * ny, x * tz + y * bz + z * nz), z


@njit(**JIT)
def _spawn(nxt, q, origin, direction, weight, parent):
    """Row q of the next generation; parent = (camera sample, row, depth,
    pdf)."""
    for a in range(3):
        nxt.origins[q, a] = origin[a]
        nxt.dirs[q, a] = direction[a]
        nxt.weight[q, a] = weight[a]
    nxt.sample[q], nxt.row[q], nxt.depth[q], nxt.pdf[q] = parent
    return q + 1


@njit(**JIT)
def _add(wave, k, rgb):
    wave.rgb[k, 0] += rgb[0]
    wave.rgb[k, 1] += rgb[1]
    wave.rgb[k, 2] += rgb[2]


@njit(**STAGE)
def shade_paths(shading, textures, paths, wave, gen, ij, nxt, q, shadow, counters):
    """Rays ij = (first, end) of generation gen, while one more hit's
    shadow rays fit in shadow: a miss adds the sky, a hit its emission,
    its light samples (shadow rays) and its next ray (into nxt from row
    q).  Returns (the first ray not shaded, shadow rays, nxt's rows)."""
    geo, lights = shading.geo, shading.lights
    per_hit = lights.pos.shape[0] + 1
    m = np.int64(0)
    i, end = ij
    while i < end and m + per_hit <= shadow.origins.shape[0]:
        k, row, depth = gen.sample[i], gen.row[i], gen.depth[i]
        thr = (gen.weight[i, 0], gen.weight[i, 1], gen.weight[i, 2])
        prim = gen.hit_prim[i]
        if depth == 0:
            wave.hit_prim[k] = prim
            wave.hit_t[k] = gen.hit_t[i]
        i += 1
        if prim < 0:
            sr, sg, sb = sky(shading.background, gen.dirs[i - 1, 1])
            _add(wave, k, (thr[0] * sr, thr[1] * sg, thr[2] * sb))
            continue
        ray = make_ray(gen.origins[i - 1, 0], gen.origins[i - 1, 1], gen.origins[i - 1, 2],
                       gen.dirs[i - 1, 0], gen.dirs[i - 1, 1], gen.dirs[i - 1, 2], 0.0)
        hit = Hit(gen.hit_t[i - 1], prim, gen.hit_u[i - 1], gen.hit_v[i - 1])
        f = hit_frame(geo, ray, hit)
        if depth == 0:
            counters[row, SHADING_POINTS] += 1
            wave.normal[k, 0], wave.normal[k, 1], wave.normal[k, 2] = f.nx, f.ny, f.nz
            sxn, syn = screen_point(wave.film[k, 0], wave.film[k, 1])
            alb = surface_albedo(textures, geo, shading.cam, hit, f.mat, f.px, f.py, f.pz, sxn,
                                 syn)
        else:
            alb = point_albedo(textures, geo, hit, f.mat, f.px, f.py, f.pz)
        par = geo.mat_param[f.mat]
        if f.front and par[MAT_EMISSION] + par[MAT_EMISSION + 1] + par[MAT_EMISSION + 2] > 0.0:
            w = emitted(paths, geo, f, hit, gen.pdf[i - 1], ray)
            _add(wave, k, (thr[0] * w * par[MAT_EMISSION], thr[1] * w * par[MAT_EMISSION + 1],
                           thr[2] * w * par[MAT_EMISSION + 2]))
        if depth >= paths.max_depth:
            continue
        q, m = scatter(shading, paths, (f, hit, ray), alb, (thr, k, row, depth, path_key(
                       shading, paths, wave, k)),
                       (nxt, q, shadow, m), counters)
    return i, m, q


@njit(**JIT)
def path_key(shading, paths, wave, k):
    """Camera sample k's rng for path_pair: its hash key, its pixel's key
    (Sobol's; the hash key again when unused) and its index in the pixel."""
    pixel = wave.y[k] * shading.width + wave.x[k]
    key = hash_key(shading.seed, pixel, wave.sample[k], _PATH_SALT)
    pkey = (hash_key(shading.seed, pixel, np.int64(0), _SOBOL_SALT) if paths.sampler == SOBOL
            else key)
    return key, pkey, wave.sample[k]


@njit(**JIT)
def scatter(shading, paths, fh, alb, path, outs, counters):
    """A hit's event: the mirror or glass ray, or the Lambertian lobe's
    light samples and cosine-drawn ray; then roulette.  fh = (frame, hit,
    ray), path = (throughput, camera sample, row, depth, its random key),
    outs = (next generation, its row, shadow rays, their row).  Returns
    the next free rows of the generation and of shadow.  Dimensions of a
    bounce: (base, 0) the event, (base, 1) and (base + 1, *) the emitter
    sample, (base + 2 + light, *) each light's, then the bounce direction
    and roulette."""
    geo = shading.geo
    f, hit, ray = fh
    dx, dy, dz = ray.dx, ray.dy, ray.dz
    thr, k, row, depth, rng = path
    nxt, q, shadow, m = outs
    n_lights = shading.lights.pos.shape[0]
    base = depth * (4 + n_lights)
    par = geo.mat_param[f.mat]
    nx, ny, nz, gx, gy, gz, eps = f.nx, f.ny, f.nz, f.gx, f.gy, f.gz, f.eps
    kt = par[MAT_TRANSMIT]
    eta = 1.0
    if kt > 0.0:
        eta = 1.0 / par[MAT_IOR] if f.front else par[MAT_IOR]
    own, w_refl, w_refr = bounce_weights(par[MAT_REFLECT], kt, -(dx * nx + dy * ny + dz * nz), eta)
    u = path_rand(paths, rng, base, np.int64(0))
    # The event, chosen with its share: its weight over its probability
    # leaves the colour (Whitted's tint, or the lobe's albedo) as the
    # throughput's factor.
    event = 0 if u < own else (2 if u < own + w_refr else 1)
    pdf = 0.0
    origin = direction = (0.0, 0.0, 0.0)
    if event == 2:
        ok, tx, ty, tz = refract(dx, dy, dz, nx, ny, nz, eta)
        if ok and tx * gx + ty * gy + tz * gz >= 0.0:
            ok, tx, ty, tz = refract(dx, dy, dz, gx, gy, gz, eta)
        if ok:
            origin = (f.px - eps * gx, f.py - eps * gy, f.pz - eps * gz)
            direction = (tx, ty, tz)
        else:
            event = 1       # total internal reflection: the mirror ray
    if event == 1:
        qx, qy, qz = reflect(dx, dy, dz, nx, ny, nz)
        if qx * gx + qy * gy + qz * gz <= 0.0:
            qx, qy, qz = reflect(dx, dy, dz, gx, gy, gz)
        origin = (f.px + eps * gx, f.py + eps * gy, f.pz + eps * gz)
        direction = (qx, qy, qz)
    if event == 0:
        kd = par[MAT_DIFFUSE]
        alb = (kd * alb[0], kd * alb[1], kd * alb[2])
        sx, sy, sz = smooth_point(geo, hit, f.px, f.py, f.pz, f.side)
        lifted = (sx - f.px) * gx + (sy - f.py) * gy + (sz - f.pz) * gz > eps
        origin = (sx + eps * gx, sy + eps * gy, sz + eps * gz)
        g = par[MAT_GLOSSY]
        # The glossy lobe's share of the directions drawn (0: Lambertian only).
        pg = g / (g + max(alb[0], alb[1], alb[2])) if g > 0.0 else 0.0
        lobe = (alb, g, par[MAT_SHININESS], reflect(dx, dy, dz, nx, ny, nz), pg)
        m = next_event(shading, paths, f, origin, ((rng, base, lifted), lobe, thr, k, row), shadow,
                       m, counters)
        u1, u2 = path_pair(paths, rng, base + 2 + n_lights)
        if g > 0.0 and u < own * pg:    # the event's number, rescaled, picks the lobe
            direction = phong_direction(lobe[3], lobe[2], u1, u2)
            cos_n = nx * direction[0] + ny * direction[1] + nz * direction[2]
        else:
            direction, cos_n = cosine_direction(nx, ny, nz, u1, u2)
        if direction[0] * gx + direction[1] * gy + direction[2] * gz <= 0.0 or cos_n <= 0.0:
            return q, m     # below the flat surface: absorbed
        pdf = cos_n * _INV_PI
        if g > 0.0:         # the throughput's factor f cos / pdf, pdf the mixture's
            fc, pdf = lobe_value(lobe, nx, ny, nz, direction[0], direction[1], direction[2])
            if pdf <= 0.0:
                return q, m
            alb = (fc[0] / pdf, fc[1] / pdf, fc[2] / pdf)
    thr = (thr[0] * alb[0], thr[1] * alb[1], thr[2] * alb[2])
    if depth + 1 >= paths.roulette_depth:
        keep = min(ROULETTE_MAX, max(thr[0], thr[1], thr[2]))
        if path_rand(paths, rng, base + 3 + n_lights, np.int64(0)) >= keep:
            counters[row, ROULETTE_ENDED] += 1
            return q, m
        thr = (thr[0] / keep, thr[1] / keep, thr[2] / keep)
    counters[row, BOUNCE_RAYS] += 1
    return _spawn(nxt, q, origin, direction, thr, (k, row, depth + 1, pdf)), m


@njit(**STAGE)
def finish_paths(wave, shadow, m, counters):
    """Each of the first m shadow rays' light, if nothing blocks it, added
    to its camera sample, in the rays' order."""
    for j in range(m):
        if shadow.blocked[j]:
            counters[shadow.row[j], OCCLUDED_RAYS] += 1
        else:
            _add(wave, shadow.sample[j], (shadow.rgb[j, 0], shadow.rgb[j, 1], shadow.rgb[j, 2]))


@njit(**STAGE)
def first_paths(shading, paths, wave, n, gen):
    """The wave's n camera rays as generation 0, their samples' colours 0.
    The Sobol sampler moves each film point (camera_wave's hashed one,
    with several samples per pixel) to its own pair of dimensions."""
    for k in range(n):
        if paths.sampler == SOBOL and shading.spp > 1:
            rng = path_key(shading, paths, wave, k)
            jx, jy = path_pair(paths, rng, _FILM_PAIR)
            fx, fy = (wave.x[k] + jx) / shading.width, (wave.y[k] + jy) / shading.height
            ray, _, _ = camera_ray(shading.cam, fx, fy)
            wave.film[k, 0], wave.film[k, 1] = fx, fy
            wave.origins[k, 0], wave.origins[k, 1], wave.origins[k, 2] = ray.ox, ray.oy, ray.oz
            wave.dirs[k, 0], wave.dirs[k, 1], wave.dirs[k, 2] = ray.dx, ray.dy, ray.dz
        for a in range(3):
            gen.origins[k, a] = wave.origins[k, a]
            gen.dirs[k, a] = wave.dirs[k, a]
            gen.weight[k, a] = 1.0
            wave.rgb[k, a] = 0.0
        gen.sample[k] = k
        gen.row[k] = wave.row[k]
        gen.depth[k] = 0
        gen.pdf[k] = 0.0
    return n


@njit(**BLOCK)
def run_path_stage(step, records, args):
    """One stage of a wave of paths but its shading (run_path_shade; the
    Python side: path_waves.py); records: (shading, textures, paths, wave,
    bufs, counters, band) packed (packed.py, as wavefront.run_stage's),
    bufs = (this generation, the next, shadow rays); args five ints, the
    result three.  CAMERA: camera_wave (args as wavefront.run_stage's) and
    generation 0; returns (rays, 0, 0).  FINISH: finish_paths of args[0]
    shadow rays.  STORE: store_wave of the wave's args[0] samples."""
    shading, _, paths, wave, bufs, counters, band = unpack(records)
    gen, _, shadow = bufs
    a, b, c, d, e = args
    if step == CAMERA:
        n = camera_wave(shading, wave, a, b, (c, d), counters, band.row0, e != 0)
        return first_paths(shading, paths, wave, n, gen), 0, 0
    if step == FINISH:
        finish_paths(wave, shadow, a, counters)
    else:
        store_wave(shading, wave, a, band)
    return 0, 0, 0


@njit(**BLOCK)
def run_path_shade(records, args):
    """SHADE: shade_paths of rays args[0] .. args[1] - 1, the next
    generation from row args[2]; returns its three numbers; records:
    run_path_stage's but the band.  An entry of its own, most of the path
    tracer's compile: a first run compiles it in the second process
    (renderer/ahead.py) while this one compiles the structure's kernels
    and run_path_stage."""
    shading, textures, paths, wave, bufs, counters = unpack(records)
    gen, nxt, shadow = bufs
    a, b, c, _, _ = args
    return shade_paths(shading, textures, paths, wave, gen, (a, b), nxt, c, shadow, counters)


def path_records(shading, textures, paths, wave, bufs, counters, band=None):
    """run_path_stage's records (run_path_shade's without ``band``), packed."""
    record = (shading, textures, paths, wave, bufs, counters)
    return Packed(record if band is None else record + (band,))


def path_buffers(rays):
    """A generation's arrays; every ray's interval, (0, inf), filled once."""
    f8, i8 = np.float64, np.int64
    return PathRays(origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                    t_min=np.zeros(rays), t_max=np.full(rays, np.inf), hit_t=np.empty(rays, f8),
                    hit_prim=np.empty(rays, i8), hit_u=np.empty(rays, f8),
                    hit_v=np.empty(rays, f8), sample=np.empty(rays, i8), row=np.empty(rays, i8),
                    depth=np.empty(rays, i8), weight=np.empty((rays, 3), f8),
                    pdf=np.empty(rays, f8))


def light_ray_buffers(rays):
    """Arrays for ``rays`` shadow rays (t_min 0; t_max set per ray)."""
    f8, i8 = np.float64, np.int64
    return LightRays(origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                     t_min=np.zeros(rays), t_max=np.ones(rays), row=np.empty(rays, i8),
                     blocked=np.empty(rays, np.bool_), sample=np.empty(rays, i8),
                     rgb=np.empty((rays, 3), f8))
