"""Brute force: every bounded primitive, every ray (the workshop's Step 1)."""
import numpy as np
from numba import njit

from raytrace.accel.brute.build import Brute
from raytrace.kernels.jit import JIT
from raytrace.kernels.prims import n_bounded, test_and_keep
from raytrace.kernels.query import ALL_HITS, ANY_HIT, CLOSEST, register
from raytrace.kernels.ray import no_hit


def _scan(mode):
    """The scan, for one of query.py's modes (a compile-time constant: one
    loop for every query, tinybvh's IsAnyHit)."""
    @njit(**JIT)
    def scan(geo, ray, t_max, cnt):
        n = n_bounded(geo)
        best = no_hit()
        # An int64, not a literal 0: typing the loop would compile
        # test_and_keep, and every test below it, for the literal first.
        p = np.int64(0)
        while p < n and not (mode == ANY_HIT and best.prim >= 0):
            best = test_and_keep(geo, ray, p, t_max, best, cnt, mode != ALL_HITS)
            p += 1
        return best
    return scan


SCANS = tuple(_scan(mode) for mode in (CLOSEST, ANY_HIT, ALL_HITS))


def _with_layout(scan):
    @njit(**JIT)
    def traverse(geo, acc, ray, t_max, cnt):
        return scan(geo, ray, t_max, cnt)
    return traverse


register(Brute, *(_with_layout(scan) for scan in SCANS))
