"""The two questions every structure answers (pbrt's Intersect/IntersectP):
the closest hit of a camera ray, and whether a shadow ray is blocked.

Dispatch is on the integer ``acc.mode`` so one compiled kernel serves every
structure (function objects passed into kernels make slow, non-deterministic
cache keys).
"""
import numpy as np
from numba import njit

from ..buffers import ACCEL_BVOL, ACCEL_GRID, ACCEL_NONE
from .flat import (brute_closest, brute_occluded, bvol_closest, bvol_occluded,
                   planes_closest, planes_occluded)
from .grid import grid_closest, grid_occluded
from .intersect import INLINE


@njit(**INLINE)
def closest_hit(geo, acc, ray, t_max, cnt, stack):
    """Returns (t, prim, b1, b2); prim is -1 and t inf on a miss.

    cnt: the caller's counter row; stack: its scratch traversal stack.
    """
    mode = acc.mode
    if mode == ACCEL_NONE:
        t, p, u, v = brute_closest(geo, ray, t_max, cnt)
    elif mode == ACCEL_BVOL:
        t, p, u, v = bvol_closest(geo, acc, ray, t_max, cnt)
    elif mode == ACCEL_GRID:
        t, p, u, v = grid_closest(geo, acc, ray, t_max, cnt)
    else:
        t, p, u, v = np.inf, -1, 0.0, 0.0
    return planes_closest(geo, ray, t_max, t, p, u, v, cnt)


@njit(**INLINE)
def occluded(geo, acc, ray, t_max, cnt, stack):
    """Any hit with 0 < t < t_max; stops at the first occluder found."""
    # Planes first: one test each, and the ground blocks many shadow rays.
    hit = planes_occluded(geo, ray, t_max, cnt)
    if not hit:
        mode = acc.mode
        if mode == ACCEL_NONE:
            hit = brute_occluded(geo, ray, t_max, cnt)
        elif mode == ACCEL_BVOL:
            hit = bvol_occluded(geo, acc, ray, t_max, cnt)
        elif mode == ACCEL_GRID:
            hit = grid_occluded(geo, acc, ray, t_max, cnt)
    return hit
