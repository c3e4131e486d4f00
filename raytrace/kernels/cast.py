"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with."""
import numpy as np
from numba import njit, prange

from .intersect import KERNEL, make_ray
from .query import closest_hit, occluded


@njit(**KERNEL)
def cast_closest(geo, acc, origins, dirs, t_max, out_t, out_prim, out_u, out_v, cnt_rows):
    """Closest hit of ray i = (origins[i], dirs[i]) with 0 < t < t_max[i].

    cnt_rows (blocks, N_COUNTERS) gives each block of rays its own counters,
    so threads never share one (the kernel, compiled without the NRT,
    allocates nothing).
    """
    n = origins.shape[0]
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for i in range(b * n // n_blocks, (b + 1) * n // n_blocks):
            ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                           dirs[i, 0], dirs[i, 1], dirs[i, 2])
            t, p, u, v = closest_hit(geo, acc, ray, t_max[i], cnt)
            out_t[i] = t
            out_prim[i] = p
            out_u[i] = u
            out_v[i] = v


@njit(**KERNEL)
def cast_occluded(geo, acc, origins, dirs, t_max, out_hit, cnt_rows):
    n = origins.shape[0]
    n_blocks = cnt_rows.shape[0]
    for b in prange(n_blocks):
        cnt = cnt_rows[b]
        for i in range(b * n // n_blocks, (b + 1) * n // n_blocks):
            ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                           dirs[i, 0], dirs[i, 1], dirs[i, 2])
            out_hit[i] = occluded(geo, acc, ray, t_max[i], cnt)
