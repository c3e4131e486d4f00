"""Mirror and glass rays as waves: Whitted (1980) on the wavefront stages.

A wave's camera rays are the first generation of its rays; each hit of a
generation is shaded (its own share of the light, with shadow rays, as
wavefront.py's stages do) and spawns the next generation's reflected and
refracted rays, until none is left or ``max_depth`` stops them.

A recursive tracer (and the megakernel this replaced) traces each camera
sample's tree of rays depth first (reflected before refracted), summing
the light as it goes.  Here a
generation is traced at once, so each ray carries its place in the tree,
``key``: one base-3 digit a level, most significant first (0: the tree
ends above, 1: reflected, 2: refracted).  Sorted by key, a sample's
contributions are in that depth-first order, and summed in it they give
the same bits.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.buffers import MAT_IOR, MAT_REFLECT, MAT_TRANSMIT
from raytrace.kernels.counters import (
    DEPTH_LIMITED,
    REFLECTION_RAYS,
    REFRACTION_RAYS,
    SHADING_POINTS,
)
from raytrace.kernels.jit import BLOCK, JIT, STAGE
from raytrace.kernels.limits import MAX_BOUNCES
from raytrace.kernels.optics import bounce_weights, reflect, refract
from raytrace.kernels.packed import Packed, unpack
from raytrace.kernels.ray import Hit, make_ray
from raytrace.kernels.render import hit_frame, point_albedo, screen_point, sky, surface_albedo
from raytrace.kernels.wavefront import light_entries, lit, room_for_hit

# A generation's rays: origin, direction and interval as cast.py takes
# them, their hits, the camera sample each serves (``sample``: its index in
# the wave) and counts for (``row``), its key, depth, RGB weight, the weight
# of its surface's own shading (``own``: weight times the material's own
# share; -1 where it has none), ambient term and light entries.

Rays = namedtuple("Rays", ["origins", "dirs", "t_min", "t_max", "hit_t", "hit_prim", "hit_u",
                           "hit_v", "sample", "row", "key", "depth", "weight", "own", "rgb",
                           "entries"])
# Each contribution to a sample's colour: the sample, the key of the ray
# that made it and its RGB; and scratch to sort them by sample (order, and
# start and fill: one row a sample and one more).
Light = namedtuple("Light", ["sample", "key", "rgb", "order", "start", "fill"])

# The key's digit of level d (1 .. MAX_BOUNCES): 3 ** (MAX_BOUNCES - d).
DIGIT = np.array([3 ** (MAX_BOUNCES - d) if d >= 1 else 0 for d in range(MAX_BOUNCES + 1)],
                 np.int64)
_REFLECTED, _REFRACTED = 1, 2
_KINDS = np.array([_REFLECTED, _REFRACTED], np.int64)

# The steps of a wave with mirror and glass rays: run_bounce_stage's, and
# SHADE, run_bounce_shade's.
FIRST, SHADE, FINISH, GATHER = 0, 1, 2, 3


@njit(**STAGE)
def _first_generation(wave, n, gen):
    """The wave's n camera rays as generation 0 (key 0, weight 1)."""
    for k in range(n):
        for a in range(3):
            gen.origins[k, a] = wave.origins[k, a]
            gen.dirs[k, a] = wave.dirs[k, a]
            gen.weight[k, a] = 1.0
        gen.sample[k] = k
        gen.row[k] = wave.row[k]
        gen.key[k] = 0
        gen.depth[k] = 0
    return n


@njit(**JIT)
def _add_light(light, c, sample, key, rgb):
    light.sample[c] = sample
    light.key[c] = key
    light.rgb[c, 0], light.rgb[c, 1], light.rgb[c, 2] = rgb
    return c + 1


@njit(**JIT)
def _spawn(nxt, p, parent, origin, direction, weight, kind, gen):
    """Row p of the next generation: gen's ray ``parent``'s child of
    ``kind`` (_REFLECTED or _REFRACTED; an array element, so not a literal
    that a call would be compiled for)."""
    for a in range(3):
        nxt.origins[p, a] = origin[a]
        nxt.dirs[p, a] = direction[a]
        nxt.weight[p, a] = weight[a]
    nxt.sample[p] = gen.sample[parent]
    nxt.row[p] = gen.row[parent]
    nxt.key[p] = gen.key[parent] + kind * DIGIT[gen.depth[parent] + 1]
    nxt.depth[p] = gen.depth[parent] + 1
    return p + 1


@njit(**STAGE)
def shade_generation(shading, textures, wave, gen, ij, nxt, p, shadow, light, c, counters,
                     max_depth):
    """Shade rays ij = (first, end) of generation gen while one more hit's
    shadow rays fit: a miss adds its sky to light (from row c); a hit gets
    its ambient term and light entries (and shadow rays), and spawns its
    reflected and refracted rays into nxt from row p.  Returns (the first
    ray not shaded, shadow rays written, nxt's rows, light's rows).
    The megakernel's arithmetic, step for step."""
    geo = shading.geo
    e = m = np.int64(0)     # not literal 0s (wavefront.shade_wave)
    i, end = ij
    while i < end and room_for_hit(shading.lights, shadow, e, m):
        gen.entries[i, 0] = e
        gen.entries[i, 1] = e
        gen.own[i, 0] = -1.0
        k, row, depth = gen.sample[i], gen.row[i], gen.depth[i]
        wr, wg, wb = gen.weight[i, 0], gen.weight[i, 1], gen.weight[i, 2]
        camera = depth == 0
        if not camera:
            # A camera ray is counted where it is made (camera_wave).
            refracted = (gen.key[i] // DIGIT[depth]) % 3 == _REFRACTED
            counters[row, REFRACTION_RAYS if refracted else REFLECTION_RAYS] += 1
        prim = gen.hit_prim[i]
        if camera:
            wave.hit_prim[k] = prim
            wave.hit_t[k] = gen.hit_t[i]
        if prim < 0:
            sr, sg, sb = sky(shading.background, gen.dirs[i, 1])
            c = _add_light(light, c, k, gen.key[i], (wr * sr, wg * sg, wb * sb))
            i += 1
            continue
        ray = make_ray(gen.origins[i, 0], gen.origins[i, 1], gen.origins[i, 2],
                       gen.dirs[i, 0], gen.dirs[i, 1], gen.dirs[i, 2], 0.0)
        hit = Hit(gen.hit_t[i], prim, gen.hit_u[i], gen.hit_v[i])
        f = hit_frame(geo, ray, hit)
        if camera:
            counters[row, SHADING_POINTS] += 1
            wave.normal[k, 0], wave.normal[k, 1], wave.normal[k, 2] = f.nx, f.ny, f.nz
            sxn, syn = screen_point(wave.film[k, 0], wave.film[k, 1])
            rgb = surface_albedo(textures, geo, shading.cam, hit, f.mat, f.px, f.py, f.pz, sxn,
                                 syn)
        else:
            rgb = point_albedo(textures, geo, hit, f.mat, f.px, f.py, f.pz)
        ar, ag, ab = rgb
        kr = geo.mat_param[f.mat, MAT_REFLECT]
        kt = geo.mat_param[f.mat, MAT_TRANSMIT]
        dx, dy, dz = ray.dx, ray.dy, ray.dz
        nx, ny, nz, gx, gy, gz, eps = f.nx, f.ny, f.nz, f.gx, f.gy, f.gz, f.eps
        eta = 1.0
        if kt > 0.0:
            ior = geo.mat_param[f.mat, MAT_IOR]
            eta = 1.0 / ior if f.front else ior
        own, w_refl, w_refr = bounce_weights(kr, kt, -(dx * nx + dy * ny + dz * nz), eta)
        if own > 0.0:
            gen.own[i, 0], gen.own[i, 1], gen.own[i, 2] = wr * own, wg * own, wb * own
            pixel = wave.y[k] * shading.width + wave.x[k]
            r, g, b, e, m = light_entries(shading, hit, f, rgb, ray, (pixel, wave.sample[k]),
                                          shadow, (e, m), counters, row)
            gen.rgb[i, 0], gen.rgb[i, 1], gen.rgb[i, 2] = r, g, b
            gen.entries[i, 1] = e
        if depth >= max_depth:
            counters[row, DEPTH_LIMITED] += (w_refl > 0.0) + (w_refr > 0.0)
            i += 1
            continue
        if w_refr > 0.0:
            ok, tx, ty, tz = refract(dx, dy, dz, nx, ny, nz, eta)
            if ok and tx * gx + ty * gy + tz * gz >= 0.0:
                ok, tx, ty, tz = refract(dx, dy, dz, gx, gy, gz, eta)
            if ok:
                p = _spawn(nxt, p, i, (f.px - eps * gx, f.py - eps * gy, f.pz - eps * gz),
                           (tx, ty, tz), (wr * w_refr * ar, wg * w_refr * ag, wb * w_refr * ab),
                           _KINDS[1], gen)
            else:
                w_refl += w_refr
        if w_refl > 0.0:
            qx, qy, qz = reflect(dx, dy, dz, nx, ny, nz)
            if qx * gx + qy * gy + qz * gz <= 0.0:
                qx, qy, qz = reflect(dx, dy, dz, gx, gy, gz)
            p = _spawn(nxt, p, i, (f.px + eps * gx, f.py + eps * gy, f.pz + eps * gz),
                       (qx, qy, qz), (wr * w_refl * ar, wg * w_refl * ag, wb * w_refl * ab),
                       _KINDS[0], gen)
        i += 1
    return i, m, p, c


@njit(**STAGE)
def finish_generation(shading, gen, ij, shadow, light, c, counters):
    """The light of rays ij = (first, end) of gen that have their own
    shading (their ambient term plus the lights they see, lit) times that
    share's weight, into light from row c; returns light's rows."""
    for i in range(ij[0], ij[1]):
        if gen.own[i, 0] < 0.0:
            continue
        r, g, b = lit(shading, shadow, (gen.entries[i, 0], gen.entries[i, 1]),
                      (gen.rgb[i, 0], gen.rgb[i, 1], gen.rgb[i, 2]), counters, gen.row[i])
        c = _add_light(light, c, gen.sample[i], gen.key[i],
                       (gen.own[i, 0] * r, gen.own[i, 1] * g, gen.own[i, 2] * b))
    return c


@njit(**STAGE)
def gather(wave, n, light, c):
    """Each of the wave's n samples' colour: its contributions (light's c
    rows) summed in order of their keys, from 0."""
    start, fill, order = light.start, light.fill, light.order
    start[:n + 1] = 0
    for j in range(c):
        start[light.sample[j] + 1] += 1
    for k in range(n):
        start[k + 1] += start[k]
        fill[k] = start[k]
    for j in range(c):
        k = light.sample[j]
        order[fill[k]] = j
        fill[k] += 1
    for k in range(n):
        lo, hi = start[k], start[k + 1]
        for a in range(lo + 1, hi):     # insertion sort by key: a sample has few
            j = order[a]
            b = a
            while b > lo and light.key[order[b - 1]] > light.key[j]:
                order[b] = order[b - 1]
                b -= 1
            order[b] = j
        r = g = bl = 0.0
        for a in range(lo, hi):
            j = order[a]
            r += light.rgb[j, 0]
            g += light.rgb[j, 1]
            bl += light.rgb[j, 2]
        wave.rgb[k, 0], wave.rgb[k, 1], wave.rgb[k, 2] = r, g, bl


@njit(**BLOCK)
def run_bounce_shade(records, args):
    """The SHADE step of a wave with mirror and glass rays (waves._Generations):
    shade_generation of rays args[0] .. args[1] - 1, the next generation
    from row args[2], light from row args[3], max_depth args[4]; returns its
    four numbers.  records: bounce_records'.  An entry of its own, apart
    from run_bounce_stage's other steps: a first render of mirrors after the
    shading stages are cached compiles the two in two processes at once
    (renderer/ahead.py), 1.6 and 1.0 s, where the one entry took 2.5."""
    shading, textures, wave, bufs, counters = unpack(records)
    gen, nxt, shadow, light = bufs
    a, b, c, d, e = args
    return shade_generation(shading, textures, wave, gen, (a, b), nxt, c, shadow, light, d,
                            counters, e)


@njit(**BLOCK)
def run_bounce_stage(step, records, args):
    """The other steps of a wave with mirror and glass rays (the Python side:
    waves._Generations), between wavefront.run_stage's CAMERA, which makes
    the wave's camera rays, and its FINISH over no rays, which stores the
    samples' colours: the steps both renders share are compiled once, in
    run_stage.  records: bounce_records' (shading, textures, wave, bufs,
    counters), packed (packed.py: their ninety-odd arrays unboxed one by
    one cost the wrapper 0.4 s more), bufs = (this generation, the next,
    shadow rays, light); args five ints, the result four.  FIRST: the
    wave's args[0] camera rays as generation 0; returns (rays, ...).
    FINISH: finish_generation of rays args[0] .. args[1] - 1, light from
    row args[2]; returns (light's rows, ...).  GATHER: the colours of the
    wave's args[0] samples from args[1] rows of light.  SHADE is
    run_bounce_shade's."""
    shading, textures, wave, bufs, counters = unpack(records)
    gen, nxt, shadow, light = bufs
    a, b, c, d, e = args
    if step == FIRST:
        return _first_generation(wave, a, gen), 0, 0, 0
    if step == FINISH:
        return finish_generation(shading, gen, (a, b), shadow, light, c, counters), 0, 0, 0
    gather(wave, a, light, b)
    return 0, 0, 0, 0


def bounce_records(shading, textures, wave, bufs, counters):
    """run_bounce_stage's and run_bounce_shade's records, packed."""
    return Packed((shading, textures, wave, bufs, counters))


def generation_buffers(rays):
    """A generation's arrays; every ray's interval, (0, inf), filled once."""
    f8, i8 = np.float64, np.int64
    return Rays(origins=np.empty((rays, 3), f8), dirs=np.empty((rays, 3), f8),
                t_min=np.zeros(rays), t_max=np.full(rays, np.inf), hit_t=np.empty(rays, f8),
                hit_prim=np.empty(rays, i8), hit_u=np.empty(rays, f8), hit_v=np.empty(rays, f8),
                sample=np.empty(rays, i8), row=np.empty(rays, i8), key=np.empty(rays, i8),
                depth=np.empty(rays, i8), weight=np.empty((rays, 3), f8),
                own=np.empty((rays, 3), f8), rgb=np.empty((rays, 3), f8),
                entries=np.empty((rays, 2), i8))


def light_buffers(rows, samples):
    i8 = np.int64
    return Light(sample=np.empty(rows, i8), key=np.empty(rows, i8),
                 rgb=np.empty((rows, 3), np.float64), order=np.empty(rows, i8),
                 start=np.empty(samples + 1, i8), fill=np.empty(samples + 1, i8))
