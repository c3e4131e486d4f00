"""kd-tree traversal, front to back (pbrt-v3's KdTreeAccel::Intersect is the
model): clip the ray to the tree's box, then at each interior node visit
the child on the origin's side of the plane first, and the other later if
the ray reaches the plane within the node's t-range.

Why the answer equals brute force bit for bit: the argument of the grid
(accel/grid/traverse.py), with nodes for cells.  The t-ranges are rounded, so a
point of the ray near a plane may be credited to the node on either side;
the build lists every primitive in each node its box widened by grid_eps
touches, which covers that rounding, and a node is skipped only when its
computed range starts beyond the best hit (with STOP_SCALE's margin).
Rays from beyond ~1e6 scene sizes, or with subnormal direction components,
test every primitive instead, as the grid's do.
"""
import numpy as np
from numba import njit

from raytrace.accel.brute.traverse import SCANS
from raytrace.accel.grid.build import grid_eps
from raytrace.accel.grid.traverse import GUARD_ULPS, STOP_SCALE
from raytrace.accel.kdtree.build import LEAF, MAX_DEPTH, KdTree
from raytrace.kernels.counters import BOX_TESTS, NODES_VISITED
from raytrace.kernels.intersect import _slab
from raytrace.kernels.jit import JIT
from raytrace.kernels.lowlevel import frame_array
from raytrace.kernels.prims import test_and_keep
from raytrace.kernels.query import ALL_HITS, ANY_HIT, CLOSEST, register
from raytrace.kernels.ray import no_hit

STACK_SIZE = MAX_DEPTH + 2   # one pending far child a level
_U = 2.0 ** -53
_DONE = -1


@njit(**JIT)
def _clip(ray, lo, hi, t_max):
    """(t0, t1) of the ray inside the tree's box (t0 > t1: it misses)."""
    t0, t1 = _slab(ray.ox, ray.inv_x, lo[0], hi[0], 0.0, t_max)
    t0, t1 = _slab(ray.oy, ray.inv_y, lo[1], hi[1], t0, t1)
    return _slab(ray.oz, ray.inv_z, lo[2], hi[2], t0, t1)


@njit(**JIT)
def _walkable(ray, lo, hi):
    """The grid's guard: the DDA-style argument holds for this ray."""
    mag = max(abs(ray.ox), abs(ray.oy), abs(ray.oz), abs(lo[0]), abs(lo[1]), abs(lo[2]),
              abs(hi[0]), abs(hi[1]), abs(hi[2]))
    return (GUARD_ULPS * _U * mag <= grid_eps(lo, hi)
            and (ray.dx == 0.0 or abs(ray.inv_x) < np.inf)
            and (ray.dy == 0.0 or abs(ray.inv_y) < np.inf)
            and (ray.dz == 0.0 or abs(ray.inv_z) < np.inf))


def _traversal(mode):
    """The walk, for one of query.py's modes (a compile-time constant).

    Every hit (ALL_HITS) scans all primitives instead: a primitive lies in
    every leaf its box touches, and counting it once per ray would need a
    per-ray record the kernels cannot allocate (as for the grid)."""
    scan = SCANS[mode]

    @njit(**JIT)
    def traverse(geo, acc, ray, t_max, cnt):
        best = no_hit()
        axis_of, split_of, index_of, count_of, plist = (acc.node_axis, acc.node_split,
                                                        acc.node_index, acc.node_count,
                                                        acc.prim_list)
        if axis_of.shape[0] == 0:
            return best
        cnt[BOX_TESTS] += 1
        tmin, tmax = _clip(ray, acc.lo, acc.hi, t_max)
        if not tmin <= tmax:
            return best
        if mode == ALL_HITS or not _walkable(ray, acc.lo, acc.hi):
            return scan(geo, ray, t_max, cnt)
        stack = frame_array(STACK_SIZE, np.int64)
        stack_t0 = frame_array(STACK_SIZE, np.float64)
        stack_t1 = frame_array(STACK_SIZE, np.float64)
        sp = 0
        node = 0
        visited = 0
        while node != _DONE:
            # Skip a node that starts beyond the best hit: none of its
            # primitives can be closer.
            if tmin * STOP_SCALE <= best.t:
                visited += 1
                axis = axis_of[node]
                if axis != LEAF:
                    s = split_of[node]
                    # Selects, not a tuple indexed by axis (which Numba
                    # lowers through memory).
                    if axis == 0:
                        oa, da, ia = ray.ox, ray.dx, ray.inv_x
                    elif axis == 1:
                        oa, da, ia = ray.oy, ray.dy, ray.inv_y
                    else:
                        oa, da, ia = ray.oz, ray.dz, ray.inv_z
                    below_first = oa < s or (oa == s and da <= 0.0)
                    first = node + 1 if below_first else index_of[node]
                    second = index_of[node] if below_first else node + 1
                    if da == 0.0:
                        node = first       # parallel to the plane: one side only
                        continue
                    t_plane = (s - oa) * ia
                    if t_plane > tmax or t_plane <= 0.0:
                        node = first
                    elif t_plane < tmin:
                        node = second
                    else:
                        stack[sp] = second
                        stack_t0[sp] = t_plane
                        stack_t1[sp] = tmax
                        sp += 1
                        node = first
                        tmax = t_plane
                    continue
                k = index_of[node]
                end = k + count_of[node]
                while k < end and not (mode == ANY_HIT and best.prim >= 0):
                    best = test_and_keep(geo, ray, plist[k], t_max, best, cnt, mode != ALL_HITS)
                    k += 1
            if (mode == ANY_HIT and best.prim >= 0) or sp == 0:
                node = _DONE
            else:
                sp -= 1
                node = stack[sp]
                tmin = stack_t0[sp]
                tmax = stack_t1[sp]
        cnt[NODES_VISITED] += visited
        return best
    return traverse


register(KdTree, *(_traversal(mode) for mode in (CLOSEST, ANY_HIT, ALL_HITS)))
