"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with.

Rays are split into blocks, each with its own counter row (cnt_rows), so
threads never share a counter and the kernels, compiled without the NRT,
allocate nothing.  A block is every n_blocks-th chunk of CHUNK consecutive
rays, not one contiguous range: prange gives each thread a contiguous range
of blocks, and rays in pixel order cost unevenly (sky, object, ground), so
contiguous blocks would leave a thread idle while interleaved chunks balance
(and the rays within a chunk stay neighbours, which keeps caches warm).
"""
from numba import njit, prange

from .intersect import KERNEL, make_ray
from .query import closest_hit, occluded

CHUNK = 64


@njit(**KERNEL)
def cast_closest(geo, acc, origins, dirs, t_max, out_t, out_prim, out_u, out_v, cnt_rows):
    """Closest hit of ray i = (origins[i], dirs[i]) with 0 < t < t_max[i]."""
    n = origins.shape[0]
    n_blocks = cnt_rows.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for c in range(b, n_chunks, n_blocks):
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                               dirs[i, 0], dirs[i, 1], dirs[i, 2])
                t, p, u, v = closest_hit(geo, acc, ray, t_max[i], cnt)
                out_t[i] = t
                out_prim[i] = p
                out_u[i] = u
                out_v[i] = v


@njit(**KERNEL)
def cast_occluded(geo, acc, origins, dirs, t_max, out_hit, cnt_rows):
    """Whether anything is hit with 0 < t < t_max[i] (stops at the first)."""
    n = origins.shape[0]
    n_blocks = cnt_rows.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for c in range(b, n_chunks, n_blocks):
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                               dirs[i, 0], dirs[i, 1], dirs[i, 2])
                out_hit[i] = occluded(geo, acc, ray, t_max[i], cnt)
