"""The two questions every structure answers (pbrt's Intersect/IntersectP):
the closest hit of a camera ray, and whether a shadow ray is blocked.

Dispatch is on the integer ``acc.mode`` so one compiled kernel serves every
structure (function objects passed into kernels make slow, non-deterministic
cache keys).

Both are compiled without Numba's reference counting (``_nrt=False``): a
per-ray call taking ``geo`` and ``acc`` (31 arrays) otherwise increments and
decrements every array's count, atomics on memory all threads share, which
measured ~10x the cost of the BVH query itself.  Nothing here allocates;
callees inherit the setting unless they set ``_nrt`` themselves, so a
structure whose query must allocate declares ``_nrt=True``.
"""
import numpy as np
from numba import njit

from ..buffers import ACCEL_BVH, ACCEL_BVOL, ACCEL_NONE
from .bvh import bvh_closest, bvh_occluded
from .flat import (brute_closest, brute_occluded, bvol_closest, bvol_occluded,
                   planes_closest, planes_occluded)
from .intersect import JIT


NOREF = dict(JIT, _nrt=False)


@njit(**NOREF)
def closest_hit(geo, acc, ray, t_max, cnt):
    """Returns (t, prim, b1, b2); prim is -1 and t inf on a miss."""
    mode = acc.mode
    if mode == ACCEL_NONE:
        t, p, u, v = brute_closest(geo, ray, t_max, cnt)
    elif mode == ACCEL_BVOL:
        t, p, u, v = bvol_closest(geo, acc, ray, t_max, cnt)
    elif mode == ACCEL_BVH:
        t, p, u, v = bvh_closest(geo, acc, ray, t_max, cnt)
    else:
        t, p, u, v = np.inf, -1, 0.0, 0.0
    return planes_closest(geo, ray, t_max, t, p, u, v, cnt)


@njit(**NOREF)
def occluded(geo, acc, ray, t_max, cnt):
    """Any hit with 0 < t < t_max; stops at the first occluder found."""
    # Planes first: one test each, and the ground blocks many shadow rays.
    if planes_occluded(geo, ray, t_max, cnt):
        return True
    mode = acc.mode
    if mode == ACCEL_NONE:
        return brute_occluded(geo, ray, t_max, cnt)
    if mode == ACCEL_BVOL:
        return bvol_occluded(geo, acc, ray, t_max, cnt)
    if mode == ACCEL_BVH:
        return bvh_occluded(geo, acc, ray, t_max, cnt)
    return False
