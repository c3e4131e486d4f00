"""The two questions every structure answers (pbrt's Intersect/IntersectP):
the closest hit of a camera ray, and whether a shadow ray is blocked.

Dispatch is on the integer ``acc.mode`` so one compiled kernel serves every
structure (function objects passed into kernels make slow, non-deterministic
cache keys).

Both are inlined into the calling kernel (inline="always").  As a plain
per-ray call, passing ``geo`` and ``acc`` copies ~270 words of array
descriptors and increments and decrements all 31 arrays' reference counts
(atomics on memory every thread shares): ~400 ns per ray with an empty
structure, more than a BVH query.  Inlined into cast_closest's prange loop a
BVH query on a 1k-triangle mesh takes 146 ns, against 182 ns as a plain call
compiled without reference counting.  Caveat: in a serial (non-prange) njit
loop Numba does not prune the reference counts that inlining creates
(355 ns); such a caller should run its loop in a function compiled with
``_nrt=False``.  Called from Python they compile without reference counting.
"""
import numpy as np
from numba import njit

from ..buffers import ACCEL_BVH, ACCEL_BVOL, ACCEL_NONE
from .bvh import bvh_closest, bvh_occluded
from .flat import (brute_closest, brute_occluded, bvol_closest, bvol_occluded,
                   planes_closest, planes_occluded)
from .intersect import JIT


NOREF = dict(JIT, _nrt=False)


@njit(inline="always", **NOREF)
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


@njit(inline="always", **NOREF)
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
