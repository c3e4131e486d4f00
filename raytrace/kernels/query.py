"""The two questions every structure answers (pbrt's Intersect/IntersectP):
the closest hit of a camera ray, and whether a shadow ray is blocked.

Dispatch is on the integer ``acc.mode`` so one compiled kernel serves every
structure (function objects passed into kernels make slow, non-deterministic
cache keys).  Both are inlined into the calling kernel, which is compiled
without reference counting (see intersect.KERNEL): as a plain per-ray call,
passing ``geo`` and ``acc`` copies ~270 words of array descriptors and, with
reference counting, increments and decrements all 31 arrays: ~400 ns per ray
with an empty structure, more than a whole BVH query.
"""
import numpy as np
from numba import njit

from ..buffers import ACCEL_BVH, ACCEL_BVOL, ACCEL_GRID, ACCEL_NONE
from .bvh import bvh_closest, bvh_occluded
from .flat import (brute_closest, brute_occluded, bvol_closest, bvol_occluded,
                   planes_closest, planes_occluded)
from .grid import grid_closest, grid_occluded
from .intersect import INLINE


@njit(**INLINE)
def closest_hit(geo, acc, ray, t_max, cnt):
    """Returns (t, prim, b1, b2); prim is -1 and t inf on a miss.

    cnt: the caller's counter row (never shared between threads).
    """
    mode = acc.mode
    if mode == ACCEL_BVH:
        t, p, u, v = bvh_closest(geo, acc, ray, t_max, cnt)
    elif mode == ACCEL_GRID:
        t, p, u, v = grid_closest(geo, acc, ray, t_max, cnt)
    elif mode == ACCEL_BVOL:
        t, p, u, v = bvol_closest(geo, acc, ray, t_max, cnt)
    elif mode == ACCEL_NONE:
        t, p, u, v = brute_closest(geo, ray, t_max, cnt)
    else:
        t, p, u, v = np.inf, -1, 0.0, 0.0
    return planes_closest(geo, ray, t_max, t, p, u, v, cnt)


@njit(**INLINE)
def occluded(geo, acc, ray, t_max, cnt):
    """Any hit with 0 < t < t_max; stops at the first occluder found."""
    # Planes first: one test each, and the ground blocks many shadow rays.
    hit = planes_occluded(geo, ray, t_max, cnt)
    if not hit:
        mode = acc.mode
        if mode == ACCEL_BVH:
            hit = bvh_occluded(geo, acc, ray, t_max, cnt)
        elif mode == ACCEL_GRID:
            hit = grid_occluded(geo, acc, ray, t_max, cnt)
        elif mode == ACCEL_BVOL:
            hit = bvol_occluded(geo, acc, ray, t_max, cnt)
        elif mode == ACCEL_NONE:
            hit = brute_occluded(geo, ray, t_max, cnt)
    return hit
