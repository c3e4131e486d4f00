"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with.

Rays go out in chunks of CHUNK consecutive rays.  Each counter block b (a
row of cnt_rows, so threads never share a counter and the kernels, compiled
without the NRT, allocate nothing; one per thread, rayscene.py) takes the
next chunk nobody has taken, by a ticket from ``clock`` (a one-element
array, 0 at the call: lowlevel.take_ticket), until none is left.  So the
threads sweep the rays once, together, neighbouring chunks at about the
same time (the cache reuse between neighbouring rays: separate sweeps were
12% slower at 118k triangles), and a thread slowed by another process on
its core takes fewer chunks instead of holding up the call.  A fixed share
each (chunks b, b + n_blocks, ...) measured the same on a quiet machine
and 7-10% slower with a process spinning 4 ms in 8 on one core (1k teapot,
camera and shadow rays through RayScene).

Rays are checked as they are read (``ray_ok``): a bad one is not traced,
its output is a miss, and it is counted in column BAD_RAYS of the counter
rows, after the declared counters, so the Python layer names the problem
after the call.  A separate pass over the rays cost 0.57 ms of a 4.0 ms
call (211,731 shadow rays, 1k teapot): 14% of the call.

Each kernel is compiled once per structure (query.py), on first use.
"""
from numba import njit, prange

from ..io.mesh import MAX_COORD
from .counters import N_COUNTERS
from .jit import JIT, PARALLEL
from .lowlevel import take_ticket
from .query import closest_hit, count_hits, occluded
from .ray import make_crossing_ray, make_ray, no_hit

CHUNK = 64
_ALL_PEELED = 1 << 62   # above every primitive id
BAD_RAYS = N_COUNTERS   # counter rows have N_COUNTERS + 1 columns
COLUMNS = N_COUNTERS + 1


@njit(**JIT)
def ray_ok(origins, dirs, t_min, t_max, i):
    """Whether ray i's origin and direction components are finite and within
    MAX_COORD, its direction is not zero, and 0 <= t_min < t_max (t_max may
    be inf).  Comparisons are written so that NaN fails them."""
    ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
    dx, dy, dz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
    return ((abs(ox) <= MAX_COORD) & (abs(oy) <= MAX_COORD) & (abs(oz) <= MAX_COORD)
            & (abs(dx) <= MAX_COORD) & (abs(dy) <= MAX_COORD) & (abs(dz) <= MAX_COORD)
            & ((dx != 0.0) | (dy != 0.0) | (dz != 0.0))
            & (t_min[i] >= 0.0) & (t_min[i] < t_max[i]))


@njit(**JIT)
def _ray(origins, dirs, t_min, i):
    return make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                    dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])


@njit(**JIT)
def _closest_block(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v, cnt,
                   clock):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    c = take_ticket(clock)
    while c < n_chunks:
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if ray_ok(origins, dirs, t_min, t_max, i):
                hit = closest_hit(geo, acc, _ray(origins, dirs, t_min, i), t_max[i], cnt)
            else:
                cnt[BAD_RAYS] += 1
                hit = no_hit()
            out_t[i] = hit.t
            out_prim[i] = hit.prim
            out_u[i] = hit.u
            out_v[i] = hit.v
        c = take_ticket(clock)


@njit(**JIT)
def _occluded_block(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt, clock):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    c = take_ticket(clock)
    while c < n_chunks:
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if ray_ok(origins, dirs, t_min, t_max, i):
                out_hit[i] = occluded(geo, acc, _ray(origins, dirs, t_min, i), t_max[i], cnt)
            else:
                cnt[BAD_RAYS] += 1
                out_hit[i] = False
        c = take_ticket(clock)


@njit(**PARALLEL)
def cast_closest(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v,
                 cnt_rows, clock):
    """Closest hit of ray i = (origins[i], dirs[i]) with t_min[i] < t < t_max[i]."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _closest_block(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v,
                       cnt_rows[b], clock)


@njit(**PARALLEL)
def cast_occluded(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt_rows, clock):
    """Whether anything is hit with t_min[i] < t < t_max[i] (stops at the first)."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _occluded_block(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt_rows[b], clock)


@njit(**JIT)
def _crossings_block(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t,
                     out_prim, out_u, out_v, counts, cnt, clock):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    fill = offsets.shape[0] > 0
    c = take_ticket(clock)
    while c < n_chunks:
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            t_lo = t_min[i]
            after = _ALL_PEELED   # t_min itself is excluded, as for every query
            k = 0
            more = ray_ok(origins, dirs, t_min, t_max, i)
            if not more:
                cnt[BAD_RAYS] += 1
            while more and k < max_hits:
                ray = make_crossing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                                        dirs[i, 0], dirs[i, 1], dirs[i, 2], t_lo, after)
                hit = closest_hit(geo, acc, ray, t_max[i], cnt)
                more = hit.prim >= 0
                if more:
                    if fill:
                        j = offsets[i] + k
                        out_t[j] = hit.t
                        out_prim[j] = hit.prim
                        out_u[j] = hit.u
                        out_v[j] = hit.v
                    t_lo = hit.t
                    after = hit.prim
                    k += 1
            counts[i] = k
        c = take_ticket(clock)


@njit(**PARALLEL)
def cast_crossings(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t, out_prim,
                   out_u, out_v, counts, cnt_rows, clock):
    """Every hit of ray i with t_min[i] < t < t_max[i], at most max_hits, in
    order of (t, primitive id), each crossing of a closed surface once: the
    closest hit, then the closest past it, and so on (CrossingRay).  counts
    gets the number; with offsets (n,) the hits are written from
    out_*[offsets[i]] on; with offsets empty, only counted."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _crossings_block(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t,
                         out_prim, out_u, out_v, counts, cnt_rows[b], clock)


@njit(**JIT)
def _counts_block(geo, acc, origins, dirs, t_min, t_max, out_count, cnt, clock):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    c = take_ticket(clock)
    while c < n_chunks:
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if not ray_ok(origins, dirs, t_min, t_max, i):
                cnt[BAD_RAYS] += 1
                out_count[i] = 0
                continue
            ray = make_crossing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                                    dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i], _ALL_PEELED)
            out_count[i] = count_hits(geo, acc, ray, t_max[i], cnt)
        c = take_ticket(clock)


@njit(**PARALLEL)
def cast_counts(geo, acc, origins, dirs, t_min, t_max, out_count, cnt_rows, clock):
    """How many times ray i meets the surfaces with t_min[i] < t < t_max[i],
    each crossing of a closed surface once: one traversal that never
    narrows the interval, with the crossing triangle test (CrossingRay)."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _counts_block(geo, acc, origins, dirs, t_min, t_max, out_count, cnt_rows[b], clock)
