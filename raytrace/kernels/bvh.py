"""BVH traversal: closest hit (pbrt's Intersect) and any hit (IntersectP).

The tree is the flattened depth-first layout of ``Accel`` (buffers.py), built
by ``raytrace.accel.bvh.build_bvh``.  At an interior node both children's
boxes are tested and the one the ray enters first is visited first; the other
waits on a fixed 64-entry stack with its entry distance, and is skipped when
popped if a hit closer than that entry has been found since.  The builder
caps depth below 64 and the stack holds at most one node per level, so it
cannot overflow.  (Accel stores no split axis, so pbrt's direction-sign order
would need another array; entry-distance order measured 1.3x faster than
always-left-first on a 1k-triangle mesh, 2.2x on 100k.)

The stack lives in the function's frame (``_frame_array``, an alloca) rather
than in ``np.empty``: that would need Numba's reference-counted runtime in
the loop and a heap allocation per ray.

Conventions shared with flat.py, so the result is bit-identical to brute
force: primitive tests get the ray's own t_max and hits are merged with
``closer`` (distance, then smaller id); box tests get min(best_t, t_max),
inclusive.  Counters are kept in locals and added to ``cnt`` once per ray.
"""
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array

from .counters import BOX_TESTS, NODES_VISITED, PRIM_HITS, PRIM_TESTS
from .flat import closer
from .intersect import ray_aabb, ray_sphere, ray_triangle

STACK_SIZE = 64  # > builder's MAX_DEPTH: one postponed sibling per level


@intrinsic
def _frame_array(typingctx, size, dtype):
    """A (size,) array in the calling function's stack frame (alloca).

    No heap allocation and no meminfo, so no reference counting; it must not
    outlive the function that creates it (it is only passed down).
    """
    if not isinstance(size, types.IntegerLiteral) or not isinstance(dtype, types.NumberClass):
        return None
    arrty = types.Array(dtype.instance_type, 1, "C")

    def codegen(context, builder, sig, args):
        n = size.literal_value
        elt = context.get_value_type(dtype.instance_type)
        itemsize = context.get_abi_sizeof(elt)
        data = cgutils.alloca_once(builder, elt, size=n)
        ary = context.make_array(arrty)(context, builder)
        intp = context.get_value_type(types.intp)
        populate_array(ary, data=data, shape=[ir.Constant(intp, n)],
                       strides=[ir.Constant(intp, itemsize)],
                       itemsize=ir.Constant(intp, itemsize), meminfo=None)
        return ary._getvalue()

    return arrty(size, dtype), codegen


# Everything below is inlined at Numba-IR level (inline="always"): into
# bvh_closest/bvh_occluded, and through query.closest_hit/occluded into the
# caller's ray loop.  An ordinary call per ray copies its array arguments
# (the 31 arrays of geo and acc are ~270 words) and, with reference counting,
# increments and decrements each one.  The triangle and sphere tests are
# recompiled from the shared source (py_func) to be inlined the same way
# (as calls: 172 vs 145 ns per ray, 1k triangles); ray_aabb and closer are
# small enough for LLVM to inline as they are.  Same code, same float
# operations (no fastmath): hits stay bit-identical to flat.py's.  Compiled
# standalone, nothing here counts references (_nrt=False): it only reads
# arrays its caller keeps alive.
NOREF = dict(_nrt=False, error_model="numpy")
_ray_triangle = njit(inline="always", **NOREF)(ray_triangle.py_func)
_ray_sphere = njit(inline="always", **NOREF)(ray_sphere.py_func)


@njit(inline="always", **NOREF)
def _test_prim(tri_v0, tri_v1, tri_v2, sph_center, sph_radius, ray, p, t_max):
    """flat.test_prim on unpacked arrays: (t, b1, b2) of bounded primitive p."""
    n_tris = tri_v0.shape[0]
    if p < n_tris:
        return _ray_triangle(ray, tri_v0, tri_v1, tri_v2, p, t_max)
    t = _ray_sphere(ray, sph_center, sph_radius, p - n_tris, t_max)
    return t, 0.0, 0.0


@njit(inline="always", **NOREF)
def _pop(stack, stack_t, sp, best_t):
    """Nearest-last postponed subtree whose entry (measured when it was
    pushed) does not lie beyond best_t; (-1, 0) when none is left."""
    while sp > 0:
        sp -= 1
        if stack_t[sp] <= best_t:
            return stack[sp], sp
    return -1, 0


# The loops are inlined into bvh_closest/bvh_occluded, next to the stack
# arrays: as a separate function taking the stack as an argument, LLVM must
# assume stack stores may alias the node arrays and reloads them (measured
# 250 vs 175 ns per ray on a 1k-triangle mesh).
@njit(inline="always", **NOREF)
def _closest_loop(node_lo, node_hi, node_start, node_count, prim_ids,
                  tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                  ray, t_max, stack, stack_t, cnt):
    best_t, best_p, best_u, best_v = np.inf, -1, 0.0, 0.0
    if node_start.shape[0] == 0:
        return best_t, best_p, best_u, best_v
    n_box = 1
    n_nodes = 0
    n_tests = 0
    n_hits = 0
    node = 0 if ray_aabb(ray, node_lo, node_hi, 0, t_max) < np.inf else -1
    sp = 0
    while node >= 0:
        n_nodes += 1
        c = node_count[node]
        if c > 0:
            s = node_start[node]
            for k in range(s, s + c):
                p = prim_ids[k]
                n_tests += 1
                t, u, v = _test_prim(tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                                     ray, p, t_max)
                if t < np.inf:
                    n_hits += 1
                    if closer(t, p, best_t, best_p):
                        best_t, best_p, best_u, best_v = t, p, u, v
            node, sp = _pop(stack, stack_t, sp, best_t)
        else:
            left = node + 1
            right = node_start[node]
            tb = min(best_t, t_max)
            dl = ray_aabb(ray, node_lo, node_hi, left, tb)
            dr = ray_aabb(ray, node_lo, node_hi, right, tb)
            n_box += 2
            # Written so LLVM can use selects: the near/far order is a coin
            # flip for the branch predictor.
            if dr < dl:
                near, far, d_near, d_far = right, left, dr, dl
            else:
                near, far, d_near, d_far = left, right, dl, dr
            if d_near < np.inf:
                stack[sp] = far  # kept only if the far child was hit too
                stack_t[sp] = d_far
                if d_far < np.inf:
                    sp += 1
                node = near
            else:
                node, sp = _pop(stack, stack_t, sp, best_t)
    cnt[BOX_TESTS] += n_box
    cnt[NODES_VISITED] += n_nodes
    cnt[PRIM_TESTS] += n_tests
    cnt[PRIM_HITS] += n_hits
    return best_t, best_p, best_u, best_v


@njit(inline="always", **NOREF)
def _occluded_loop(node_lo, node_hi, node_start, node_count, prim_ids,
                   tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                   ray, t_max, stack, cnt):
    if node_start.shape[0] == 0:
        return False
    n_box = 1
    n_nodes = 0
    n_tests = 0
    n_hits = 0
    hit = False
    node = 0 if ray_aabb(ray, node_lo, node_hi, 0, t_max) < np.inf else -1
    sp = 0
    while node >= 0:
        n_nodes += 1
        c = node_count[node]
        if c > 0:
            s = node_start[node]
            for k in range(s, s + c):
                n_tests += 1
                t, u, v = _test_prim(tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                                     ray, prim_ids[k], t_max)
                if t < np.inf:
                    n_hits += 1
                    hit = True
                    break
            if hit or sp == 0:
                break
            sp -= 1
            node = stack[sp]
        else:
            # Any hit ends the search; near-first still tends to find a
            # blocker sooner, and both tests cull misses before a push.
            left = node + 1
            right = node_start[node]
            dl = ray_aabb(ray, node_lo, node_hi, left, t_max)
            dr = ray_aabb(ray, node_lo, node_hi, right, t_max)
            n_box += 2
            if dr < dl:
                near, far, d_near, d_far = right, left, dr, dl
            else:
                near, far, d_near, d_far = left, right, dl, dr
            if d_near < np.inf:
                stack[sp] = far
                if d_far < np.inf:
                    sp += 1
                node = near
            elif sp > 0:
                sp -= 1
                node = stack[sp]
            else:
                node = -1
    cnt[BOX_TESTS] += n_box
    cnt[NODES_VISITED] += n_nodes
    cnt[PRIM_TESTS] += n_tests
    cnt[PRIM_HITS] += n_hits
    return hit


@njit(inline="always", **NOREF)
def bvh_closest(geo, acc, ray, t_max, cnt):
    """Closest bounded primitive hit with 0 < t < t_max: (t, prim, b1, b2),
    (inf, -1, 0, 0) on a miss or an empty tree."""
    stack = _frame_array(STACK_SIZE, np.int64)
    stack_t = _frame_array(STACK_SIZE, np.float64)
    return _closest_loop(acc.node_lo, acc.node_hi, acc.node_start, acc.node_count,
                         acc.prim_ids, geo.tri_v0, geo.tri_v1, geo.tri_v2,
                         geo.sph_center, geo.sph_radius, ray, t_max, stack, stack_t, cnt)


@njit(inline="always", **NOREF)
def bvh_occluded(geo, acc, ray, t_max, cnt):
    """Any bounded primitive hit with 0 < t < t_max; stops at the first."""
    stack = _frame_array(STACK_SIZE, np.int64)
    return _occluded_loop(acc.node_lo, acc.node_hi, acc.node_start, acc.node_count,
                          acc.prim_ids, geo.tri_v0, geo.tri_v1, geo.tri_v2,
                          geo.sph_center, geo.sph_radius, ray, t_max, stack, cnt)
