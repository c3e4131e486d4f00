"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with.

Rays go out in chunks of CHUNK consecutive rays; counter block b (a row of
cnt_rows, so threads never share a counter and the kernels, compiled without
the NRT, allocate nothing) takes chunks b, b + n_blocks, b + 2 n_blocks, ...
in order.  With one block per thread (rayscene.py) each thread sweeps the
rays once, a chunk at a time: rays in pixel order cost unevenly (sky,
object, ground), and prange's one contiguous range per thread would leave a
thread idle, while neighbouring chunks cost about the same.  (Many smaller
blocks would balance too, but then a thread sweeps the rays once per block
and loses the cache reuse between neighbouring rays: 12% slower at 118k
triangles.)

Each kernel is compiled once per structure (query.py), on first use.
"""
from numba import njit, prange

from .jit import JIT, PARALLEL
from .query import closest_hit, count_hits, occluded
from .ray import make_crossing_ray, make_ray

CHUNK = 64
_ALL_PEELED = 1 << 62   # above every primitive id


@njit(**JIT)
def _ray(origins, dirs, t_min, i):
    return make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                    dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])


@njit(**JIT)
def _closest_block(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v, cnt,
                   b, n_blocks):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for c in range(b, n_chunks, n_blocks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            hit = closest_hit(geo, acc, _ray(origins, dirs, t_min, i), t_max[i], cnt)
            out_t[i] = hit.t
            out_prim[i] = hit.prim
            out_u[i] = hit.u
            out_v[i] = hit.v


@njit(**JIT)
def _occluded_block(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt, b, n_blocks):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for c in range(b, n_chunks, n_blocks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            out_hit[i] = occluded(geo, acc, _ray(origins, dirs, t_min, i), t_max[i], cnt)


@njit(**PARALLEL)
def cast_closest(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v,
                 cnt_rows):
    """Closest hit of ray i = (origins[i], dirs[i]) with t_min[i] < t < t_max[i]."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _closest_block(geo, acc, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v,
                       cnt_rows[b], b, n_blocks)


@njit(**PARALLEL)
def cast_occluded(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt_rows):
    """Whether anything is hit with t_min[i] < t < t_max[i] (stops at the first)."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _occluded_block(geo, acc, origins, dirs, t_min, t_max, out_hit, cnt_rows[b], b, n_blocks)


@njit(**JIT)
def _crossings_block(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t,
                     out_prim, out_u, out_v, counts, cnt, b, n_blocks):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    fill = offsets.shape[0] > 0
    for c in range(b, n_chunks, n_blocks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            t_lo = t_min[i]
            after = _ALL_PEELED   # t_min itself is excluded, as for every query
            k = 0
            more = True
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


@njit(**PARALLEL)
def cast_crossings(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t, out_prim,
                   out_u, out_v, counts, cnt_rows):
    """Every hit of ray i with t_min[i] < t < t_max[i], at most max_hits, in
    order of (t, primitive id), each crossing of a closed surface once: the
    closest hit, then the closest past it, and so on (CrossingRay).  counts
    gets the number; with offsets (n,) the hits are written from
    out_*[offsets[i]] on; with offsets empty, only counted."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _crossings_block(geo, acc, origins, dirs, t_min, t_max, max_hits, offsets, out_t,
                         out_prim, out_u, out_v, counts, cnt_rows[b], b, n_blocks)


@njit(**JIT)
def _counts_block(geo, acc, origins, dirs, t_min, t_max, out_count, cnt, b, n_blocks):
    n = origins.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for c in range(b, n_chunks, n_blocks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            ray = make_crossing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                                    dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i], _ALL_PEELED)
            out_count[i] = count_hits(geo, acc, ray, t_max[i], cnt)


@njit(**PARALLEL)
def cast_counts(geo, acc, origins, dirs, t_min, t_max, out_count, cnt_rows):
    """How many times ray i meets the surfaces with t_min[i] < t < t_max[i],
    each crossing of a closed surface once: one traversal that never
    narrows the interval, with the crossing triangle test (CrossingRay)."""
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        _counts_block(geo, acc, origins, dirs, t_min, t_max, out_count, cnt_rows[b], b, n_blocks)
