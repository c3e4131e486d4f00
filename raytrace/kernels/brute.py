"""Brute force: every bounded primitive, every ray (the workshop's Step 1)."""
from numba import njit

from ..accel.brute import Brute
from .jit import JIT
from .prims import n_bounded, test_and_keep
from .query import register
from .ray import no_hit


def _scan(any_hit):
    """The scan; with any_hit (a compile-time constant) it stops at the
    first hit (tinybvh's IsAnyHit: one loop for both queries)."""
    @njit(**JIT)
    def scan(geo, ray, t_max, cnt):
        n = n_bounded(geo)
        best = no_hit()
        p = 0
        while p < n and not (any_hit and best.prim >= 0):
            best = test_and_keep(geo, ray, p, t_max, best, cnt)
            p += 1
        return best
    return scan


scan_closest = _scan(False)
scan_any = _scan(True)


@njit(**JIT)
def closest(geo, acc, ray, t_max, cnt):
    return scan_closest(geo, ray, t_max, cnt)


@njit(**JIT)
def any_hit(geo, acc, ray, t_max, cnt):
    return scan_any(geo, ray, t_max, cnt)


register(Brute, closest, any_hit)
