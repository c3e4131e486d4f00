"""Rays and hits as named records (pbrt's Ray and SurfaceInteraction, Ray
Tracing in One Weekend's ray and hit_record)."""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT
from raytrace.kernels.limits import FROM_ORIGIN, MAX_COORD
from raytrace.kernels.lowlevel import row_window

# Rays a thread of a query takes at a time (kernels/cast.py), and the
# float64 values of a chunk's origins or directions widened from float32
# (widen_rays: each thread's two frame arrays of WIDE).
CHUNK = 1024
WIDE = 3 * CHUNK

# A ray with the per-ray constants every test along it shares: the inverse
# direction for slab tests (a zero component gives +-inf) and the axis
# permutation (kx, ky, kz), shear (sx, sy, sz) and permuted origin (okx,
# oky, okz) of the watertight triangle test.  Hits count for t_min < t <
# t_max (t_max is the query's argument, since it shrinks as hits are found).
Ray = namedtuple("Ray", ["ox", "oy", "oz", "dx", "dy", "dz", "inv_x", "inv_y", "inv_z",
                         "kx", "ky", "kz", "sx", "sy", "sz", "okx", "oky", "okz", "t_min"])

# A ray of a crossing query (every hit along it): its triangle test gives
# an edge or vertex to one triangle only (intersect.py), so a ray crossing a
# closed surface there crosses it once.
CrossingRay = namedtuple("CrossingRay", Ray._fields)

# A CrossingRay that writes down each hit its primitive tests find, so any
# structure's counting traversal lists them (prims.py, record_hit): into
# rows cursor[0], cursor[0] + 1, ... of hit_t, hit_prim, hit_u and hit_v,
# none at or past row cursor[1].
ListingRay = namedtuple("ListingRay", Ray._fields + ("hit_t", "hit_prim", "hit_u", "hit_v",
                                                     "cursor"))

# A hit: distance, unified primitive id (-1: none) and the barycentric
# weights of a triangle's second and third vertices.
Hit = namedtuple("Hit", ["t", "prim", "u", "v"])


@njit(**JIT)
def make_ray(ox, oy, oz, dx, dy, dz, t_min=0.0):
    """A Ray from origin and direction (Woop, Benthin & Wald 2013,
    "Watertight Ray/Triangle Intersection", for the shear constants);
    t_min (FROM_ORIGIN or more) is the near end of its interval."""
    idx = 1.0 / dx
    idy = 1.0 / dy
    idz = 1.0 / dz
    ax, ay, az = abs(dx), abs(dy), abs(dz)
    # kz: the dominant axis, so the shear divides by the largest component.
    if ax > ay:
        kz = 0 if ax > az else 2
    else:
        kz = 1 if ay > az else 2
    kx = kz + 1
    if kx == 3:
        kx = 0
    ky = kx + 1
    if ky == 3:
        ky = 0
    d = (dx, dy, dz)
    dkz = d[kz]
    # Swapping kx, ky when the dominant component is negative keeps the
    # winding, so the sign of the edge functions means the same thing.
    if dkz < 0.0:
        kx, ky = ky, kx
    sx = d[kx] / dkz
    sy = d[ky] / dkz
    # 1.0 / dkz is the inverse already computed for that axis (the same
    # division, so the same bits): one division a ray fewer.
    sz = idx if kz == 0 else idy if kz == 1 else idz
    o = (ox, oy, oz)
    return Ray(ox, oy, oz, dx, dy, dz, idx, idy, idz, kx, ky, kz, sx, sy, sz, o[kx], o[ky], o[kz],
               t_min)


@njit(**JIT)
def ray_at(origins, dirs, t_min, i):
    """Row i of (n, 3) origins and directions, from t_min[i], as a Ray."""
    return make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                    dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])


@njit(**JIT)
def make_crossing_ray(ox, oy, oz, dx, dy, dz, t_min):
    r = make_ray(ox, oy, oz, dx, dy, dz, t_min)
    return CrossingRay(r.ox, r.oy, r.oz, r.dx, r.dy, r.dz, r.inv_x, r.inv_y, r.inv_z,
                       r.kx, r.ky, r.kz, r.sx, r.sy, r.sz, r.okx, r.oky, r.okz, r.t_min)


@njit(**JIT)
def make_listing_ray(ox, oy, oz, dx, dy, dz, t_min, hit_t, hit_prim, hit_u, hit_v, cursor):
    r = make_ray(ox, oy, oz, dx, dy, dz, t_min)
    return ListingRay(r.ox, r.oy, r.oz, r.dx, r.dy, r.dz, r.inv_x, r.inv_y, r.inv_z,
                      r.kx, r.ky, r.kz, r.sx, r.sy, r.sz, r.okx, r.oky, r.okz, r.t_min,
                      hit_t, hit_prim, hit_u, hit_v, cursor)


@njit(**JIT)
def no_hit():
    return Hit(np.inf, -1, 0.0, 0.0)


@njit(**JIT)
def closer(t, p, best):
    """Canonical order of hits: by distance, then by primitive id, so the
    answer does not depend on the order a structure tests primitives in."""
    return t < best.t or (t == best.t and p < best.prim)


@njit(**JIT)
def widen_rays(narrow, origins, dirs, lo, end, wide):
    """The (origins, dirs) arrays to read rays lo .. end - 1 (at most CHUNK)
    of a call from, by the call's row numbers: ``origins`` and ``dirs``
    themselves for a float64 call of (n, 3) arrays (``narrow`` empty), else
    wide = (two frame arrays of WIDE float64, the thread's) filled with
    those rays, exactly, and seen through lowlevel.row_window: from the
    call's float32 origins and directions (``narrow``: (n, 3) arrays, or
    the same (n, 6) rows twice, the origin first), or from the same
    float64 (n, 6) rows passed as ``origins`` and ``dirs`` (create_rays_pinhole's
    layout, read in place rather than copied before the call: 6 ns a ray,
    docs/benchmarks.md, "Rays in other layouts").  The widened chunk stays
    in the thread's cache until it is traced; widened into rows the size
    of the call, each call wrote them to memory and read them back
    (docs/benchmarks.md, "float32 rays widened into a thread's chunk")."""
    o32, d32 = narrow
    wo, wd = wide
    if o32.shape[0] == 0:
        if dirs.shape[1] == 3:
            return origins, dirs
        for i in range(lo, end):
            for a in range(3):
                wo[3 * (i - lo) + a] = origins[i, a]
                wd[3 * (i - lo) + a] = dirs[i, 3 + a]
    else:
        col = d32.shape[1] - 3
        for i in range(lo, end):
            for a in range(3):
                wo[3 * (i - lo) + a] = o32[i, a]
                wd[3 * (i - lo) + a] = d32[i, col + a]
    return row_window(wo, lo, end - lo), row_window(wd, lo, end - lo)


@njit(**JIT)
def ray_ok(origins, dirs, t_min, t_max, i):
    """Whether ray i's origin and direction components are finite and within
    MAX_COORD, its direction is not zero, and FROM_ORIGIN <= t_min < t_max
    (t_max may be inf).  Comparisons are written so that NaN fails them."""
    ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
    dx, dy, dz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
    return ((abs(ox) <= MAX_COORD) & (abs(oy) <= MAX_COORD) & (abs(oz) <= MAX_COORD)
            & (abs(dx) <= MAX_COORD) & (abs(dy) <= MAX_COORD) & (abs(dz) <= MAX_COORD)
            & ((dx != 0.0) | (dy != 0.0) | (dz != 0.0))
            & (t_min[i] >= FROM_ORIGIN) & (t_min[i] < t_max[i]))
