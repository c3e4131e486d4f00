"""BVH traversal: closest hit (pbrt's Intersect) and any hit (IntersectP).

The tree is the 4-wide layout of ``Accel`` (buffers.py): ``build_bvh``'s
binary tree collapsed so each node holds the boxes of up to 4 children
(``raytrace.accel.bvh.collapse_bvh4``).  At a node all 4 child boxes are
tested at once (``ray_aabb4``, SIMD); the children the ray enters go on a
fixed-size stack with their entry distances, sorted so the nearest is on top,
and the nearest is visited next.  A popped entry is skipped when a hit closer
than its entry distance has been found since.  Leaves are children too: a
stack entry below zero is ``~(node * 4 + lane)``, the leaf in that lane.

Measured on the teapot's 640x480 camera rays (cast_closest, 2 threads),
against the binary tree this replaces: about 1.9x the throughput at 1k
triangles and 1.8x at 118k (README design notes).

The stack lives in the function's frame (``frame_array``, an alloca) rather
than in ``np.empty``: that would need Numba's reference-counted runtime in
the loop and a heap allocation per ray.  Each node pushes at most 3 entries
beyond the one it pops, and a 4-wide node lies at most MAX_DEPTH - 1 levels
down (the binary tree's leaves are at most MAX_DEPTH deep), so the stack
never holds more than 3 * (MAX_DEPTH - 1) + 4 entries.

Conventions shared with flat.py, so the result is bit-identical to brute
force: primitive tests get the ray's own t_max and hits are merged with
``closer`` (distance, then smaller id); box tests get min(best_t, t_max),
inclusive.  Counters are kept in locals and added to ``cnt`` once per ray.
"""
import numpy as np
from numba import njit

from ..accel.bvh import MAX_DEPTH
from .counters import BOX_TESTS, NODES_VISITED, PRIM_HITS, PRIM_TESTS
from .flat import closer
from .intersect import ray_sphere, ray_triangle
from .lowlevel import WIDTH, frame_array, ray_aabb4

STACK_SIZE = 3 * MAX_DEPTH + 4
_LANE_BITS = WIDTH.bit_length() - 1   # a leaf's stack entry is ~(node << 2 | lane)
_DONE = -(1 << 62)  # "stack empty": below every leaf entry


# Everything below is inlined at Numba-IR level (inline="always"): into
# bvh_closest/bvh_occluded, and through query.closest_hit/occluded into the
# caller's ray loop.  An ordinary call per ray copies its array arguments
# (the 31 arrays of geo and acc are ~270 words) and, with reference counting,
# increments and decrements each one.  The triangle and sphere tests are
# recompiled from the shared source (py_func) to be inlined the same way
# (as calls: 172 vs 145 ns per ray, 1k triangles); closer is small enough
# for LLVM to inline as it is, and ray_aabb4 is emitted in place.  Same
# code, same float operations (no fastmath): hits stay bit-identical to
# flat.py's.  Compiled
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
def _push_children(node_box, node_child, node_count, node, ray, nx, ny, nz, t_box,
                   stack, stack_t, sp):
    """Test node's 4 child boxes; push the ones the ray enters, nearest on
    top (insertion into the entries pushed here, usually 1 or 2).  Returns
    the new stack pointer."""
    d = ray_aabb4(node_box, node, nx, ny, nz, ray[0], ray[1], ray[2],
                  ray[6], ray[7], ray[8], t_box)
    base = sp
    for lane in range(WIDTH):
        dl = d[lane]
        if dl < np.inf:
            entry = node_child[node, lane]
            if node_count[node, lane] > 0:
                entry = ~((node << _LANE_BITS) | lane)
            k = sp
            while k > base and stack_t[k - 1] < dl:
                stack[k] = stack[k - 1]
                stack_t[k] = stack_t[k - 1]
                k -= 1
            stack[k] = entry
            stack_t[k] = dl
            sp += 1
    return sp


@njit(inline="always", **NOREF)
def _leaf_range(node_child, node_count, entry):
    """prim_ids slots [start, end) of the leaf a stack entry ~(node << 2 | lane) names."""
    leaf = ~entry
    node = leaf >> _LANE_BITS
    lane = leaf & (WIDTH - 1)
    start = node_child[node, lane]
    return start, start + node_count[node, lane]


@njit(inline="always", **NOREF)
def _near_rows(ray):
    """Rows of node_box holding the planes a ray meets first on each axis:
    lo (0, 1, 2) for a positive inverse direction, hi (3, 4, 5) otherwise."""
    nx = 3 if ray[6] < 0.0 else 0
    ny = 4 if ray[7] < 0.0 else 1
    nz = 5 if ray[8] < 0.0 else 2
    return nx, ny, nz


# The loops are inlined into bvh_closest/bvh_occluded, next to the stack
# arrays: as a separate function taking the stack as an argument, LLVM must
# assume stack stores may alias the node arrays and reloads them (measured
# 250 vs 175 ns per ray on a 1k-triangle mesh, binary tree).
@njit(inline="always", **NOREF)
def _closest_loop(node_box, node_child, node_count, prim_ids,
                  tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                  ray, t_max, stack, stack_t, cnt):
    best_t, best_p, best_u, best_v = np.inf, -1, 0.0, 0.0
    if node_box.shape[0] == 0:
        return best_t, best_p, best_u, best_v
    nx, ny, nz = _near_rows(ray)
    n_inner = 0
    n_leaves = 0
    n_tests = 0
    n_hits = 0
    entry = 0
    sp = 0
    while entry != _DONE:
        if entry >= 0:
            n_inner += 1
            base = sp
            sp = _push_children(node_box, node_child, node_count, entry, ray, nx, ny, nz,
                                min(best_t, t_max), stack, stack_t, sp)
            if sp > base:
                # The nearest child was just pushed: its entry is within
                # best_t, so it is taken without the check below.
                sp -= 1
                entry = stack[sp]
                continue
        else:
            n_leaves += 1
            s, end = _leaf_range(node_child, node_count, entry)
            for k in range(s, end):
                p = prim_ids[k]
                n_tests += 1
                t, u, v = _test_prim(tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                                     ray, p, t_max)
                if t < np.inf:
                    n_hits += 1
                    if closer(t, p, best_t, best_p):
                        best_t, best_p, best_u, best_v = t, p, u, v
        # Pop the nearest pending entry that may still hold a closer hit.
        entry = _DONE
        while sp > 0 and entry == _DONE:
            sp -= 1
            if stack_t[sp] <= best_t:
                entry = stack[sp]
    cnt[BOX_TESTS] += WIDTH * n_inner
    cnt[NODES_VISITED] += n_inner + n_leaves
    cnt[PRIM_TESTS] += n_tests
    cnt[PRIM_HITS] += n_hits
    return best_t, best_p, best_u, best_v


@njit(inline="always", **NOREF)
def _occluded_loop(node_box, node_child, node_count, prim_ids,
                   tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                   ray, t_max, stack, stack_t, cnt):
    if node_box.shape[0] == 0:
        return False
    nx, ny, nz = _near_rows(ray)
    n_inner = 0
    n_leaves = 0
    n_tests = 0
    n_hits = 0
    hit = False
    entry = 0
    sp = 0
    while entry != _DONE:
        if entry >= 0:
            # Any hit ends the search; nearest-first still tends to find a
            # blocker sooner.
            n_inner += 1
            sp = _push_children(node_box, node_child, node_count, entry, ray, nx, ny, nz,
                                t_max, stack, stack_t, sp)
        else:
            n_leaves += 1
            k, end = _leaf_range(node_child, node_count, entry)
            while k < end and not hit:
                n_tests += 1
                t, u, v = _test_prim(tri_v0, tri_v1, tri_v2, sph_center, sph_radius,
                                     ray, prim_ids[k], t_max)
                hit = t < np.inf
                k += 1
        if hit or sp == 0:
            entry = _DONE
        else:
            sp -= 1
            entry = stack[sp]
    if hit:
        n_hits = 1
    cnt[BOX_TESTS] += WIDTH * n_inner
    cnt[NODES_VISITED] += n_inner + n_leaves
    cnt[PRIM_TESTS] += n_tests
    cnt[PRIM_HITS] += n_hits
    return hit


@njit(inline="always", **NOREF)
def bvh_closest(geo, acc, ray, t_max, cnt):
    """Closest bounded primitive hit with 0 < t < t_max: (t, prim, b1, b2),
    (inf, -1, 0, 0) on a miss or an empty tree."""
    stack = frame_array(STACK_SIZE, np.int64)
    stack_t = frame_array(STACK_SIZE, np.float64)
    return _closest_loop(acc.node_box, acc.node_child, acc.node_count, acc.prim_ids,
                         geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center, geo.sph_radius,
                         ray, t_max, stack, stack_t, cnt)


@njit(inline="always", **NOREF)
def bvh_occluded(geo, acc, ray, t_max, cnt):
    """Any bounded primitive hit with 0 < t < t_max; stops at the first."""
    stack = frame_array(STACK_SIZE, np.int64)
    stack_t = frame_array(STACK_SIZE, np.float64)
    return _occluded_loop(acc.node_box, acc.node_child, acc.node_count, acc.prim_ids,
                          geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center, geo.sph_radius,
                          ray, t_max, stack, stack_t, cnt)
