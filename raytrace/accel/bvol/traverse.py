"""Per-object bounding volumes (the workshop's Step 3): a box test per
object, then its primitives."""
import numpy as np
from numba import njit

from raytrace.accel.bvol.build import BoundingVolumes
from raytrace.kernels.counters import BOX_TESTS
from raytrace.kernels.intersect import ray_aabb
from raytrace.kernels.jit import JIT
from raytrace.kernels.prims import test_and_keep
from raytrace.kernels.query import ALL_HITS, ANY_HIT, CLOSEST, register
from raytrace.kernels.ray import no_hit


def _traversal(mode):
    @njit(**JIT)
    def traverse(geo, acc, ray, t_max, cnt):
        lo, hi, start, count = acc.obj_lo, acc.obj_hi, acc.obj_start, acc.obj_count
        best = no_hit()
        n = start.shape[0]
        j = np.int64(0)     # not a literal 0 (brute/traverse.py)
        while j < n and not (mode == ANY_HIT and best.prim >= 0):
            cnt[BOX_TESTS] += 1
            if ray_aabb(ray, lo, hi, j, min(best.t, t_max)) < np.inf:
                p = start[j]
                end = p + count[j]
                while p < end and not (mode == ANY_HIT and best.prim >= 0):
                    best = test_and_keep(geo, ray, p, t_max, best, cnt, mode != ALL_HITS)
                    p += 1
            j += 1
        return best
    return traverse


register(BoundingVolumes, *(_traversal(mode) for mode in (CLOSEST, ANY_HIT, ALL_HITS)))
