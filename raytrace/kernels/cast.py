"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with.

Rays go out in chunks of CHUNK consecutive rays; counter block b (a row of
cnt_rows, so threads never share a counter and the kernels, compiled without
the NRT, allocate nothing) takes chunks b, b + n_blocks, b + 2 n_blocks, ...
in order.  With one block per thread (raycast.py) each thread sweeps the
rays once, a chunk at a time: rays in pixel order cost unevenly (sky,
object, ground), and prange's one contiguous range per thread would leave a
thread idle, while neighbouring chunks cost about the same.  (Many smaller
blocks would balance too, but then a thread sweeps the rays once per block
and loses the cache reuse between neighbouring rays: 12% slower at 118k
triangles.)

The BVH, the default structure, gets a loop of its own: behind
query.closest_hit's dispatch over all four structures it measured 20%
slower at 1k triangles (31.6 against 39.4 Mrays/s on the teapot's camera
rays), the inlined code of the other three structures crowding it.  Same
functions, so the same answers.
"""
from numba import njit, prange

from ..buffers import ACCEL_BVH
from .bvh import bvh_closest, bvh_occluded
from .flat import planes_closest, planes_occluded
from .intersect import KERNEL, make_ray
from .query import closest_hit, occluded

CHUNK = 64


@njit(**KERNEL)
def cast_closest(geo, acc, origins, dirs, t_max, out_t, out_prim, out_u, out_v, cnt_rows):
    """Closest hit of ray i = (origins[i], dirs[i]) with 0 < t < t_max[i]."""
    n = origins.shape[0]
    n_blocks = cnt_rows.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    bvh = acc.mode == ACCEL_BVH
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for c in range(b, n_chunks, n_blocks):
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                               dirs[i, 0], dirs[i, 1], dirs[i, 2])
                if bvh:
                    t, p, u, v = bvh_closest(geo, acc, ray, t_max[i], cnt)
                    t, p, u, v = planes_closest(geo, ray, t_max[i], t, p, u, v, cnt)
                else:
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
    bvh = acc.mode == ACCEL_BVH
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for c in range(b, n_chunks, n_blocks):
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                               dirs[i, 0], dirs[i, 1], dirs[i, 2])
                if bvh:
                    hit = planes_occluded(geo, ray, t_max[i], cnt)
                    if not hit:
                        hit = bvh_occluded(geo, acc, ray, t_max[i], cnt)
                else:
                    hit = occluded(geo, acc, ray, t_max[i], cnt)
                out_hit[i] = hit
