"""Binned-SAH bounding volume hierarchy build: boxes in, flat arrays out.

Algorithm: Wald 2007, "On fast Construction of SAH-based Bounding Volume
Hierarchies" -- primitive centroids are sorted into a few equal-width bins
along each axis of the node's centroid box, and the surface area heuristic is
evaluated only at bin boundaries.  pbrt-v4 (``BVHAggregate::buildRecursive``)
and tinybvh (``BVH::Build``) are the models for the cost model and the leaf
decision (ideas only; the code is written for Numba from the paper).

The builder sees only primitive boxes (centroids come from the boxes), never
triangles or spheres, so it serves every bounded primitive alike.  It runs
entirely in one compiled function with an explicit work stack and
preallocated node arrays (a binary tree with n primitives in non-empty
leaves has at most 2n - 1 nodes): no Python object per node.

The binary tree is flattened depth-first, so an interior node's first child
is the next node; ``node_start`` of an interior node is its second child and
its ``node_count`` is 0.  A leaf covers
``prim_ids[node_start : node_start + node_count]``.  ``collapse_bvh4`` then
turns it into the 4-wide tree traversal uses (``BVH`` below).
"""
import functools
from collections import namedtuple

import numba
import numpy as np
from numba import njit

from raytrace.accel.bvh.box8 import HALF, LANES, find_bins, grow_box, grow_centroids
from raytrace.accel.bvh.f32 import f32_next
from raytrace.kernels.buffers import n_bounded, prim_bounds
from raytrace.kernels.jit import BUILD, BUILD_STEP
from raytrace.kernels.threads import run_on_threads, runs

# The layout traversal reads (raytrace/accel/bvh/traverse.py), 4 children per
# node: node_box (m, 6, 4) float32 child boxes, rows lo x, y, z, hi x, y, z,
# a lane per child; node_count (m, 4) > 0 makes a lane a leaf covering
# prim_ids[node_child : node_child + node_count], 0 an inner child, node
# node_child (or an unused lane, whose box is +inf).  prim_ids: unified ids.
# box_bound: the largest magnitude of a box coordinate (inf past float32's
# range), which bounds the float32 box test's distances (accel/bvh/traverse.py).
BVH = namedtuple("BVH", ["node_box", "node_child", "node_count", "prim_ids", "box_bound"])
# The layout counting and listing every hit read (for_counting): the
# fields of a BVH of its own, built for counting (COUNT_TRAVERSAL_COST), and
# - leaf_tris, (9, len(prim_ids) + 3) float64: column k the corners of
#   the triangle in slot k of prim_ids, row 3 * corner + axis; NaN where a
#   slot holds a sphere, and in the 3 columns past the end, so a leaf
#   loads 4 columns at a time (simd.crossing_mask);
# - lanes, (m * 4,) int64: each lane's node_child << 32 | node_count, one
#   load where a lane took two (a leaf's is its queue entry as it stands),
#   where an inner lane whose subtree holds at most COUNT_LEAF primitives
#   in contiguous slots (every builder's subtrees do) is a leaf over them,
#   so counting tests them at once instead of visiting its nodes.
CountingBVH = namedtuple("CountingBVH", BVH._fields + ("leaf_tris", "lanes"))
# One 8-lane crossing test (simd.CROSSING_LANES): 6% faster
# counts than the tree's own leaves, 10 and 16 no faster (docs/design.md).
COUNT_LEAF = 8
# The counting tree's SAH weighs a node visit as 4 triangle tests, where a
# tree for tracing weighs it as 1 (TRAVERSAL_COST): its leaves hold up to
# COUNT_LEAF triangles, tested 8 at a time, and a count visits every node
# the ray meets.  5% faster counts than on the tracing tree; 2 and 8 no
# better than 4, leaves of 16 slower (docs/design.md).
COUNT_TRAVERSAL_COST = 4.0
# The nodes' box type, binary and wide: float32, each the padded float64
# box rounded outwards (build_bvh_kernel, collapse_bvh4).
BOX = np.float32
# The binary tree's node_start and node_count (rows and counts, below 2^31
# for any mesh that fits in memory): half of int64's bytes while the
# binary and the wide tree are both held, the build's peak.
LINK = np.int32
# Children per node: one <4 x float> per box plane (simd.py).
WIDTH = 4

# 12 bins, as pbrt-v4's buckets: Wald 2007 finds 8-16 bins close to the
# full-sweep SAH, and 8..64 bins here changed nodes visited per ray by <2%
# (1k and 100k triangle meshes) while the build slows with more bins.
N_BINS = 12
# Leaves hold at most this many primitives unless no split is possible; the
# SAH may still make a smaller node a leaf.  2, 4 and 8 measured within
# noise (+-5% rays/s) on 1k and 100k triangle meshes.  --leaf-size sets it.
MAX_LEAF = 4
# Cost of one node visit (two child box tests) relative to one primitive
# test, in the SAH: C = TRAVERSAL_COST + (A_L N_L + A_R N_R) / A.  0.5, 1
# and 2 measured within noise.
TRAVERSAL_COST = 1.0
# Leaves are forced at this depth, so traversal's fixed-size stack (at most 3
# pending children per level of the 4-wide tree, accel/bvh/traverse.py) can never
# overflow: part of the layout's contract.  The 118k-triangle surface builds 21 deep; only adversarial
# inputs get here.
MAX_DEPTH = 60
# Node boxes are widened by this fraction of their largest coordinate
# magnitude.  Exact bounds are not enough for the BVH to equal brute force on
# rays through shared vertices and edges: the rounded box entry distance can
# exceed the hit distance the triangle test computes for a hit on the box's
# boundary (by ~1e-16 relative), and ray_aabb culls a ray with a -0.0
# direction component whose origin lies on a box face (NaN and -inf slab
# distances).  1e-9 is ~4x10^6 ulps: it covers rounding for ray origins up
# to ~10^5 times the node's coordinates away, and grows boxes negligibly.
BOX_PAD = 1e-9
# From this many primitives on, build() builds on every thread
# (build_bvh_parallel: the same tree); below, a small scene's first render
# does not compile the parallel path's code for little gain.
PARALLEL_MIN = 100_000
# Subtrees of at most n / SPLIT primitives are built in parallel; the top
# levels above them are serial passes over every primitive, and smaller
# subtrees balance the threads better.  4, 8 and 16 built alike fast at 1M
# and 4.2M triangles on 2 threads (32 and 128 slower), but each run of
# rows wastes up to a huge page (2 MB) at its ends: at 4.2M the peak was
# 1065 MB with 8, 1003 MB with 4.
SPLIT = 4
# At most this many subtrees split again to even out the threads' shares.
REFINE = 4


@njit(**BUILD_STEP)
def _half_area(x0, y0, z0, x1, y1, z1):
    dx = x1 - x0
    dy = y1 - y0
    dz = z1 - z0
    return dx * dy + dy * dz + dz * dx


@njit(**BUILD_STEP)
def _corners(rows, i):
    """Box row i (accel/bvh/box8.py) as float64 (lo x, y, z, hi x, y, z)."""
    return (np.float64(rows[i, 0]), np.float64(rows[i, 1]), np.float64(rows[i, 2]),
            -np.float64(rows[i, HALF]), -np.float64(rows[i, HALF + 1]),
            -np.float64(rows[i, HALF + 2]))


@njit(**BUILD_STEP)
def _row_area(rows, i):
    """Half the surface area of box row i, in float64."""
    x0, y0, z0, x1, y1, z1 = _corners(rows, i)
    return _half_area(x0, y0, z0, x1, y1, z1)


@njit(**dict(BUILD, nogil=True))
def build_bvh_kernel(boxes, prim_ids, start, end, depth, max_leaf, traversal_cost, node_lo,
                     node_hi, node_start, node_count, first, defer, tasks):
    """The binned-SAH tree over prim_ids[start:end] (reordered in place),
    its root at ``depth``, with a node visit costing ``traversal_cost``
    primitive tests (TRAVERSAL_COST for tracing rays), into node rows
    first, first + 1, ...
    depth-first.  With defer > 0, a node below the root with at most defer
    primitives is not built but left as a task: a row (node, start, end,
    depth) of ``tasks`` (n, 4), and node_count -1 at its row, for
    build_bvh_parallel to build apart.  Returns (the row after the last node,
    the deepest level, the number of tasks).  nogil: threads may build
    disjoint ranges into disjoint rows at once.

    A box's centre, 0.5 (lo + hi), is computed where it is needed: an
    array of them cost 24 bytes a primitive (100 MB at 4.2M triangles)
    and was no faster.  Each primitive's bins are found in a pass of their
    own (``bin_of``) before the bins are grown: with the bin computed
    inline, the next loads waited on each update's address, which waits
    on the float-to-int arithmetic (one count a primitive cost 14 ns
    inline, 6 ns with a precomputed address; Zen 1).  The sweeps skip
    empty bins.  Together: the same tree, 143-152 -> 118-124 ms for the
    118k-triangle teapot on one thread (docs/design.md).

    ``boxes``: the primitives' box rows (box_rows; accel/bvh/box8.py).  A
    node's box and centroid box and each bin grow 8 lanes at a time, and
    a primitive's three bins are found together: the same trees, 0.62 ->
    0.40 s for the 1M-triangle teapot on one thread (AVX-512 Xeon)."""
    bin_count = np.empty((3, N_BINS), np.int64)
    # Bin b of axis a: box row a * N_BINS + b (exact: minima of float32 rows).
    bin_box = np.empty((3 * N_BINS, LANES), BOX)
    # Scratch rows: the node's box, its centroids' (as lo + hi), and the
    # sweeps' running union.
    grown = np.empty((3, LANES), BOX)
    # right_cost[b] = N_R * A_R (half area) of bins b.. on the current axis.
    right_cost = np.empty(N_BINS, np.float64)
    bin_scale = np.empty(3, np.float64)  # bins per unit length on each axis
    # Each primitive's bin on the three axes (N_BINS fits in int8), by its
    # slot in prim_ids, from slot0: the partition moves the split axis's.
    bin_of = np.empty((end - start, 3), np.int8)
    slot0 = start

    # Work stack of pending right subtrees: (start, end, depth, parent).
    # At most one entry per level, and levels are capped at MAX_DEPTH.
    stack = np.empty((MAX_DEPTH + 2, 4), np.int64)
    sp = 0
    n_nodes = first
    max_depth = depth
    n_tasks = 0
    parent = -1
    while True:
        node = n_nodes
        n_nodes += 1
        if parent >= 0:
            node_start[parent] = node  # this is parent's second child
        if depth > max_depth:
            max_depth = depth
        count = end - start
        if node > first and count <= defer:
            # Left for another thread (build_bvh_parallel): a placeholder here.
            tasks[n_tasks, 0] = node
            tasks[n_tasks, 1] = start
            tasks[n_tasks, 2] = end
            tasks[n_tasks, 3] = depth
            n_tasks += 1
            node_count[node] = -1
        else:
            # Node box and centroid box.  A centroid is 0.5 (lo + hi):
            # halving is exact, so the box of lo + hi is halved after.
            grown[0:2, :] = np.inf
            for k in range(start, end):
                p = prim_ids[k]
                grow_box(grown, 0, boxes, p)
                grow_centroids(grown, 1, boxes, p)
            bx0, by0, bz0, bx1, by1, bz1 = _corners(grown, 0)
            cx0, cy0, cz0, cx1, cy1, cz1 = _corners(grown, 1)
            cx0, cy0, cz0, cx1, cy1, cz1 = (0.5 * cx0, 0.5 * cy0, 0.5 * cz0, 0.5 * cx1,
                                            0.5 * cy1, 0.5 * cz1)
            # A parent's largest magnitude is at least its children's, so padded
            # children stay inside padded parents (rounding is monotonic).
            pad = BOX_PAD * max(abs(bx0), abs(by0), abs(bz0), abs(bx1), abs(by1), abs(bz1))
            node_lo[node, 0] = _round_down(bx0 - pad)
            node_lo[node, 1] = _round_down(by0 - pad)
            node_lo[node, 2] = _round_down(bz0 - pad)
            node_hi[node, 0] = _round_up(bx1 + pad)
            node_hi[node, 1] = _round_up(by1 + pad)
            node_hi[node, 2] = _round_up(bz1 + pad)

            mid = -1
            if count > 1 and depth < MAX_DEPTH:
                cext = (cx1 - cx0, cy1 - cy0, cz1 - cz0)
                # Bin width as a scale; an axis whose centroids coincide (or whose
                # extent is so small the scale overflows) cannot be split.
                bin_scale[:] = 0.0
                for a in range(3):
                    if cext[a] > 0.0:
                        s = N_BINS / cext[a]
                        if s < np.inf:
                            bin_scale[a] = s
                if bin_scale[0] > 0.0 or bin_scale[1] > 0.0 or bin_scale[2] > 0.0:
                    bin_count[:, :] = 0
                    bin_box[:, :] = np.inf
                    sx, sy, sz = bin_scale[0], bin_scale[1], bin_scale[2]
                    for k in range(start, end):
                        find_bins(bin_of, k - slot0, boxes, prim_ids[k], cx0, cy0, cz0, sx, sy,
                                  sz, N_BINS - 1)
                    # Every primitive into its bin on all three axes in one pass
                    # (an axis not binned fills bin 0, which its sweep skips).
                    for k in range(start, end):
                        p = prim_ids[k]
                        b0 = bin_of[k - slot0, 0]
                        b1 = bin_of[k - slot0, 1]
                        b2 = bin_of[k - slot0, 2]
                        bin_count[0, b0] += 1
                        bin_count[1, b1] += 1
                        bin_count[2, b2] += 1
                        grow_box(bin_box, b0, boxes, p)
                        grow_box(bin_box, N_BINS + b1, boxes, p)
                        grow_box(bin_box, 2 * N_BINS + b2, boxes, p)

                    # Sweep: SAH sum A_L N_L + A_R N_R at each bin boundary.
                    # Past an empty bin a boundary has the previous one's
                    # sides and cost, so it is skipped.
                    best_cost = np.inf
                    best_axis = -1
                    best_bin = -1
                    for a in range(3):
                        if bin_scale[a] == 0.0:
                            continue
                        grown[2, :] = np.inf
                        m = 0
                        cost_right = 0.0
                        for b in range(N_BINS - 1, 0, -1):
                            c = bin_count[a, b]
                            if c:
                                m += c
                                grow_box(grown, 2, bin_box, a * N_BINS + b)
                                cost_right = m * _row_area(grown, 2)
                            right_cost[b] = cost_right
                        grown[2, :] = np.inf
                        m = 0
                        for b in range(1, N_BINS):
                            # split between bins b-1 and b
                            c = bin_count[a, b - 1]
                            if c == 0:
                                continue
                            m += c
                            grow_box(grown, 2, bin_box, a * N_BINS + b - 1)
                            if m == count:
                                continue
                            cost = m * _row_area(grown, 2) + right_cost[b]
                            if cost < best_cost:
                                best_cost = cost
                                best_axis = a
                                best_bin = b

                    # Leaf or split (costs scaled by the node's half area, so a
                    # zero-area node compares without dividing by zero).
                    area = _half_area(bx0, by0, bz0, bx1, by1, bz1)
                    leaf_cost = count * area
                    split_cost = traversal_cost * area + best_cost
                    if best_axis >= 0 and (count > max_leaf or split_cost < leaf_cost):
                        # Partition prim_ids[start:end] by the bins found
                        # above, so the sides match the counts.
                        a = best_axis
                        i = start
                        j = end - 1
                        while i <= j:
                            if bin_of[i - slot0, a] < best_bin:
                                i += 1
                            else:
                                p = prim_ids[i]
                                prim_ids[i] = prim_ids[j]
                                prim_ids[j] = p
                                bin_of[i - slot0, a] = bin_of[j - slot0, a]
                                j -= 1
                        mid = i
                elif count > max_leaf:
                    # All centroids coincide: no plane separates them, so halve
                    # the list (any order is as good as another).
                    mid = start + count // 2

            if mid > start and mid < end:
                node_count[node] = 0
                # Right half waits on the stack; the left child is built next, so
                # it becomes node + 1 and its whole subtree precedes the right.
                stack[sp, 0] = mid
                stack[sp, 1] = end
                stack[sp, 2] = depth + 1
                stack[sp, 3] = node
                sp += 1
                end = mid
                depth += 1
                parent = -1
                continue
            node_start[node] = start
            node_count[node] = count
        if sp == 0:
            break
        sp -= 1
        start = stack[sp, 0]
        end = stack[sp, 1]
        depth = stack[sp, 2]
        parent = stack[sp, 3]

    return n_nodes, max_depth, n_tasks


def collapse_bvh4(node_lo, node_hi, node_start, node_count, links=None):
    """The binary tree as a 4-wide one: (node_box, node_child, node_count4).

    Each wide node takes a binary interior node's two children, then
    repeatedly replaces the interior child with the largest surface area by
    its own two children until it has 4 (Dammertz et al. 2008; the greedy
    choice keeps the boxes a ray most likely enters together in one node).
    The children's boxes are copied as BOX (float32), rounded outwards (lo
    down, hi up) where a builder made them float64, so each still holds its
    primitives and culls only what the float64 box culls: the same hits,
    with half the bytes a node (a ray reads 96 of them a node, not 192).
    Lane j of wide node i: node_box[i, :, j] is
    the box (rows lo x, y, z, hi x, y, z); node_count4[i, j] > 0 makes it a
    leaf over prim_ids[node_child[i, j] : + node_count4[i, j]], 0 an interior
    child, wide node node_child[i, j].  Unused lanes: box lo = hi = +inf,
    which no ray enters, and count 0.  Wide nodes are numbered depth-first.
    A single-leaf tree becomes one wide node with one leaf lane.

    ``links``: for a tree not in one depth-first run of rows (build_bvh_parallel):
    (root, top, top_first, n_inner): the root's row, the first row from
    which a node's first child is top_first[row - top] instead of row + 1,
    and the number of interior nodes.
    """
    m = len(node_start)
    # Every wide node is made of a binary interior node (a lone leaf: the
    # root), and takes up to three: so at most that many, usually about a
    # third.  np.empty: the kernel fills the rows it uses, and the pages of
    # the rest are never touched, so they cost no memory (np.full of this
    # bound and a trimmed copy took 1.8 s and 900 MB at 4.2M triangles).
    if links is None:
        links = (0, m, _NO_FIRST, int(np.count_nonzero(node_count == 0)))
    root, top, top_first, n_inner = links
    cap = max(n_inner, 1)
    node_box = np.empty((cap, 6, WIDTH), BOX)
    node_child = np.empty((cap, WIDTH), np.int64)
    count4 = np.empty((cap, WIDTH), np.int64)
    if m == 0:
        return node_box[:0], node_child[:0], count4[:0]
    kids = np.empty(WIDTH, np.int64)
    # Pending interior children: (binary node, slot of the wide lane that
    # will point at it).  A wide node pushes at most WIDTH.
    stack = np.empty(((MAX_DEPTH + 2) * WIDTH, 2), np.int64)
    n_wide = collapse_bvh4_kernel(node_lo, node_hi, node_start, node_count, root, top, top_first,
                                  node_box, node_child, count4, kids, stack)
    # Views of the rows used: the rest of each allocation stays untouched.
    return node_box[:n_wide], node_child[:n_wide], count4[:n_wide]


@njit(**BUILD_STEP)
def _round_down(x):
    """The largest float32 at most x (x itself if it is one)."""
    f = np.float32(x)
    if f > x:
        f = f32_next(f, False)
    return f


@njit(**BUILD_STEP)
def _round_up(x):
    """The smallest float32 at least x."""
    f = np.float32(x)
    if f < x:
        f = f32_next(f, True)
    return f


@njit(**BUILD)
def collapse_bvh4_kernel(node_lo, node_hi, node_start, node_count, root, top, top_first,
                         node_box, node_child, count4, kids, stack):
    """collapse_bvh4's loop, into the arrays its caller allocates; returns
    the number of wide nodes."""
    sp = 0
    n_wide = 1
    src = root   # binary node the current wide node is made of
    wide = 0
    while True:
        if node_count[src] > 0:
            n_kids = 1
            kids[0] = src
        else:
            n_kids = 2
            kids[0] = src + 1 if src < top else top_first[src - top]
            kids[1] = node_start[src]
            while n_kids < WIDTH:
                best = -1
                best_area = -1.0
                for j in range(n_kids):
                    k = kids[j]
                    if node_count[k] == 0:
                        area = _half_area(node_lo[k, 0], node_lo[k, 1], node_lo[k, 2],
                                          node_hi[k, 0], node_hi[k, 1], node_hi[k, 2])
                        if area > best_area:
                            best_area = area
                            best = j
                if best < 0:
                    break
                k = kids[best]
                kids[best] = k + 1 if k < top else top_first[k - top]
                kids[n_kids] = node_start[k]
                n_kids += 1
        for j in range(n_kids, WIDTH):          # unused lanes: a box no ray enters
            for a in range(6):
                node_box[wide, a, j] = np.inf
            node_child[wide, j] = -1
            count4[wide, j] = 0
        for j in range(n_kids):
            k = kids[j]
            for a in range(3):
                node_box[wide, a, j] = _round_down(node_lo[k, a])
                node_box[wide, 3 + a, j] = _round_up(node_hi[k, a])
            count4[wide, j] = 0
            if node_count[k] > 0:
                node_child[wide, j] = node_start[k]
                count4[wide, j] = node_count[k]
            else:
                stack[sp, 0] = k
                stack[sp, 1] = wide * WIDTH + j
                sp += 1
        if sp == 0:
            break
        sp -= 1
        src = stack[sp, 0]
        slot = stack[sp, 1]
        wide = n_wide
        n_wide += 1
        node_child[slot // WIDTH, slot % WIDTH] = wide
    return n_wide


def outward(lo, hi):
    """Boxes (lo, hi) as BOX (float32) arrays, rounded outwards, so each
    holds the box it comes from.  The float64 arrays may go once this
    returns: half the bytes through the build."""
    out = []
    for x, away in ((lo, -np.inf), (hi, np.inf)):
        x = np.asarray(x, np.float64).reshape(-1, 3)
        with np.errstate(over="ignore"):    # beyond float32's range: +-inf, still outwards
            y = x.astype(BOX)
        y += BOX(0.0)     # -0.0 is 0.0: NumPy's minimum of the two may give either
        off = y > x if away < 0 else y < x
        y[off] = np.nextafter(y[off], BOX(away))
        out.append(y)
    return out


def box_rows(lo, hi):
    """BOX boxes (lo, hi) (from ``outward``) as the builder's box rows,
    (n, LANES): lo x, y, z, 0, -hi x, y, z, 0 (accel/bvh/box8.py)."""
    lo, hi = np.asarray(lo).reshape(-1, 3), np.asarray(hi).reshape(-1, 3)
    if lo.shape != hi.shape:
        raise ValueError(f"box arrays differ in shape: {lo.shape} vs {hi.shape}")
    rows = np.zeros((len(lo), LANES), BOX)
    rows[:, :3] = lo
    rows[:, HALF:HALF + 3] = -hi
    return rows


@njit(**dict(BUILD, nogil=True))
def box_bounds_kernel(v0, v1, v2, centre, radius, start, end, boxes):
    """Rows [start, end) of ``box_rows(*outward(*prim_bounds(geo)))``
    (unified ids: triangles, then spheres) in one pass, into ``boxes``:
    the float64 boxes are never stored.  nogil, so threads fill disjoint
    rows."""
    n_tris = v0.shape[0]
    for p in range(start, end):
        for a in range(3):
            if p < n_tris:
                low = min(min(v0[p, a], v1[p, a]), v2[p, a])
                high = max(max(v0[p, a], v1[p, a]), v2[p, a])
            else:
                low = centre[p - n_tris, a] - radius[p - n_tris]
                high = centre[p - n_tris, a] + radius[p - n_tris]
            boxes[p, a] = _round_down(low) + np.float32(0.0)     # as outward(): no -0.0
            boxes[p, HALF + a] = -(_round_up(high) + np.float32(0.0))
        boxes[p, HALF - 1] = 0.0
        boxes[p, LANES - 1] = 0.0


def box_bounds(geo, threads):
    """``box_rows(*outward(*prim_bounds(geo)))`` on ``threads`` threads,
    for big meshes (small ones do not compile it).  At 4.2M triangles the
    two steps took 0.25-0.76 s in one test, this 0.03-0.09 s: 200 MB of
    float64 boxes are never made, nor their pages faulted in."""
    n = n_bounded(geo)
    boxes = np.empty((n, LANES), BOX)
    args = (geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center, geo.sph_radius)
    run_on_threads([functools.partial(box_bounds_kernel, *args, s, e, boxes)
                    for s, e in runs(n, threads)])
    return boxes


def _parallel_threads(n_prims, bvh_build):
    """Threads for build_bvh_parallel and box_bounds: Numba's, for the SAH
    builder from PARALLEL_MIN primitives on and with more than one; else 0."""
    threads = numba.get_num_threads()
    big = BUILDERS[bvh_build] is None and n_prims >= PARALLEL_MIN
    return threads if big and threads > 1 else 0


def load_big(n_prims, bvh_build="sah", **_):
    """Load (or compile) box_bounds_kernel if a scene of n_prims primitives
    will use it (Structure.load: compile time is not build time)."""
    if _parallel_threads(n_prims, bvh_build):
        rows = np.zeros((0, 3))
        box_bounds_kernel(rows, rows, rows, rows, np.zeros(0), 0, 0, np.empty((0, LANES), BOX))


def build_bvh(lo, hi, max_leaf=MAX_LEAF, traversal_cost=TRAVERSAL_COST):
    """Binned-SAH BVH over (n, 3) primitive boxes ``lo``, ``hi`` (float64,
    or BOX from ``outward``).

    Returns (node_lo, node_hi, node_start, node_count, prim_ids) as documented
    on ``Accel``; prim_ids are the row indices of ``lo``/``hi`` (unified
    primitive ids when the boxes come from ``prim_bounds``).  n == 0 gives
    zero-length arrays, which traversal treats as "nothing to hit".  The
    tree's boxes are BOX, rounded outwards from the padded float64 ones.
    """
    if np.asarray(lo).dtype != BOX or np.asarray(hi).dtype != BOX:
        lo, hi = outward(lo, hi)
    boxes = box_rows(lo, hi)
    n = len(boxes)
    # np.empty at the bound (a binary tree over n primitives in non-empty
    # leaves has at most 2n - 1 nodes): the rows never written cost no
    # memory, and views of those written are returned, not copies.
    rows = max(2 * n - 1, 0)
    nodes = (np.empty((rows, 3), BOX), np.empty((rows, 3), BOX), np.empty(rows, LINK),
             np.empty(rows, LINK))
    prim_ids = np.arange(n)
    if n == 0:
        return (*nodes, prim_ids)
    n_nodes, _, _ = build_bvh_kernel(boxes, prim_ids, 0, n, 0, int(max_leaf),
                                     float(traversal_cost), *nodes, 0, 0, _NO_TASKS)
    return tuple(a[:n_nodes] for a in nodes) + (prim_ids,)


_NO_TASKS = np.empty((0, 4), np.int64)
_NO_FIRST = np.empty(0, np.int64)


# ---------------------------------------------------------------- parallel build
#
# The binned-SAH BVH built on every thread: the serial builder's tree, so
# the same 4-wide tree, statistics and images.
#
# The top of the tree is built first, by the serial loop, until nodes hold
# at most n / SPLIT primitives; those are left as tasks.  A task's subtree
# owns its range [s, e) of prim_ids, so the tasks are built at once on
# Python threads (the builder releases the GIL), each by the same loop,
# each into its own run of rows starting at row 2 s: a subtree over e - s
# primitives has at most 2 (e - s) - 1 nodes, so the runs never meet.  The
# top's nodes follow, from row 2 n.  Nothing is copied afterwards (a copy
# into depth-first order touched fresh pages, which cost more here than a
# second thread gained, docs/design.md): the collapse into the 4-wide tree
# follows the top's first-child links explicitly (``links``), and every
# subtree is depth-first within its run.  Rows between the runs are never
# written, so they cost no memory.
#
# Tasks go to threads largest first, each to the least loaded (LPT
# scheduling).  Where that leaves one thread much more work than the mean
# (7 near-equal subtrees on 2 threads: 3 against 4, 42.8 against 53.4 ms
# at 118k triangles), the largest task's root is split first, serially
# (one pass over its primitives), its two children taking its place, at
# most REFINE times.  The root's row goes after the top's, so the top stays
# one run of rows.


def build_bvh_parallel(boxes, max_leaf, threads=None, split=SPLIT, refine=REFINE,
                       traversal_cost=TRAVERSAL_COST):
    """(node_lo, node_hi, node_start, node_count, prim_ids, links) of the
    serial builder's tree over box rows ``boxes`` (box_rows), built on ``threads``
    threads (default: Numba's); ``links`` is collapse_bvh4's (root, top,
    top_first, n_inner) for rows laid out as above.  ``refine``: how many
    tasks may be split to even out the threads' shares."""
    threads = threads or numba.get_num_threads()
    n = len(boxes)
    top = 2 * n
    # The top's rows hold its nodes and placeholders, at most the serial
    # tree's 2 n - 1, and three a split task (its root, two placeholders).
    rows = top + max(2 * n - 1, 1) + 3 * refine
    nodes = (np.empty((rows, 3), BOX), np.empty((rows, 3), BOX), np.empty(rows, LINK),
             np.empty(rows, LINK))
    node_count = nodes[3]
    prim_ids = np.arange(n)
    tasks = np.empty((n, 4), np.int64)
    cost = float(traversal_cost)
    top_end, _, n_tasks = build_bvh_kernel(boxes, prim_ids, 0, n, 0, max_leaf, cost, *nodes, top,
                                           max(n // split, 1), tasks)
    tasks = tasks[:n_tasks].copy()   # the (n, 4) bound goes
    split_to = {}   # a split task's placeholder row -> its root's row in the top
    queues = _plan(tasks, threads)
    while refine > 0 and _uneven(tasks, queues, threads):
        k = int(np.argmax(tasks[:, 2] - tasks[:, 1]))
        row, s, e, depth = (int(x) for x in tasks[k])
        if e - s < 2 * max_leaf:
            break
        more = np.empty((2, 4), np.int64)
        split_to[row] = top_end
        top_end, _, n_more = build_bvh_kernel(boxes, prim_ids, s, e, depth, max_leaf, cost, *nodes,
                                              top_end, e - s - 1, more)
        tasks = np.concatenate([np.delete(tasks, k, axis=0), more[:n_more]])
        queues = _plan(tasks, threads)
        refine -= 1
    n_tasks = len(tasks)
    ends = np.empty(n_tasks, np.int64)
    no_tasks = tasks[:0]

    def work(queue):
        for k in queue:
            s, e, depth = (int(x) for x in tasks[k, 1:])
            ends[k] = build_bvh_kernel(boxes, prim_ids, s, e, depth, max_leaf, cost, *nodes, 2 * s,
                                       0, no_tasks)[0]
    run_on_threads([functools.partial(work, q) for q in queues])
    # A top node's children are rows of the top, or placeholders (count -1)
    # whose subtrees' roots are at row 2 s: link past the placeholders.
    root_of = dict(zip(tasks[:, 0].tolist(), (2 * tasks[:, 1]).tolist())) | split_to
    top_first = np.arange(top + 1, top_end + 1)
    inner = np.flatnonzero(node_count[top:top_end] == 0) + top
    for r in inner.tolist():
        top_first[r - top] = root_of.get(r + 1, r + 1)
        nodes[2][r] = root_of.get(int(nodes[2][r]), int(nodes[2][r]))
    n_inner = len(inner) + sum(int(np.count_nonzero(node_count[2 * s:end] == 0))
                               for s, end in zip(tasks[:, 1].tolist(), ends.tolist()))
    return (*nodes, prim_ids, (top, top, top_first, n_inner))


def _plan(tasks, threads):
    """Each thread's task numbers: largest first, each to the least loaded."""
    queues = [[] for _ in range(threads)]
    load = [0] * threads
    for k in sorted(range(len(tasks)), key=lambda k: tasks[k, 1] - tasks[k, 2]):
        th = load.index(min(load))
        queues[th].append(k)
        load[th] += int(tasks[k, 2] - tasks[k, 1])
    return queues


def _uneven(tasks, queues, threads):
    """Whether the most loaded thread has over 5% more primitives than the
    mean share."""
    size = tasks[:, 2] - tasks[:, 1]
    most = max(int(size[q].sum()) for q in queues)
    return most > 1.05 * int(size.sum()) / threads


# The binary tree's builders: name -> module with build_binary(lo, hi,
# leaf_size); "sah" is this module's.  Each gives the same images.
BUILDERS = {"sah": None, "median": "raytrace.accel.bvh.median", "lbvh": "raytrace.accel.bvh.lbvh"}


def build(geo, obj_ranges, bvh_build="sah", leaf_size=MAX_LEAF, traversal_cost=TRAVERSAL_COST,
          **_):
    """A BVH over every bounded primitive (planes have no box and are tested
    separately by every structure), built by ``bvh_build`` with leaves of at
    most ``leaf_size`` primitives, collapsed to 4 children per node.  The
    SAH builder weighs a node visit as ``traversal_cost`` primitive tests."""
    links = None
    threads = _parallel_threads(n_bounded(geo), bvh_build)
    if threads:
        boxes = box_bounds(geo, threads)
        *binary, links = build_bvh_parallel(boxes, int(leaf_size), threads,
                                            traversal_cost=traversal_cost)
        del boxes   # the boxes go before the wide tree is made: 32 bytes a primitive
    else:
        lo, hi = outward(*prim_bounds(geo))   # the float64 boxes go at once
        if BUILDERS[bvh_build] is None:
            binary = build_bvh(lo, hi, leaf_size, traversal_cost)
        else:
            import importlib
            binary = importlib.import_module(BUILDERS[bvh_build]).build_binary(lo, hi,
                                                                               int(leaf_size))
        del lo, hi
    node_lo, node_hi, node_start, node_count, prim_ids = binary
    del binary
    node_box, node_child, node_count4 = collapse_bvh4(node_lo, node_hi, node_start, node_count,
                                                      links)
    return BVH(node_box=node_box, node_child=node_child, node_count=node_count4, prim_ids=prim_ids,
               box_bound=box_bound(node_box))


def box_bound(node_box):
    """The largest magnitude of any box coordinate of the tree: the root's
    lanes', since every box holds its children's."""
    if len(node_box) == 0:
        return 0.0
    root = node_box[0]
    return float(np.abs(root[:, root[0] < np.inf]).max(initial=0.0))


def for_counting(bvh, geo):
    """The CountingBVH of the scene whose tracing tree is ``bvh``: a tree of
    its own over the same primitives, built for counting (leaves of up to
    COUNT_LEAF, COUNT_TRAVERSAL_COST), made on a scene's first count or
    listing (cast/rayscene.py), never for a render.  The answers are the same on
    any tree (the tests are exact); ``bvh``'s builder and leaf size are
    not used."""
    tree = build(geo, None, leaf_size=COUNT_LEAF, traversal_cost=COUNT_TRAVERSAL_COST)
    return counting_copy(tree, geo)


def counting_copy(bvh, geo):
    """The CountingBVH over tree ``bvh``: its triangles' corners copied in
    leaf order (72 bytes a triangle) and its lanes packed (8 bytes a
    lane).  Counting loads a leaf's triangles as 4 contiguous columns where
    it gathered 9 coordinates from 3 arrays for each (docs/design.md,
    "Counting decides 4 triangles at once")."""
    ids = bvh.prim_ids
    leaf_tris = np.full((9, len(ids) + 3), np.nan)
    slots = np.flatnonzero(ids < geo.tri_v0.shape[0])
    tris = ids[slots]
    for corner, v in enumerate((geo.tri_v0, geo.tri_v1, geo.tri_v2)):
        for axis in range(3):
            leaf_tris[3 * corner + axis, slots] = v[tris, axis]
    child, count = bvh.node_child, bvh.node_count
    inner = (count == 0) & (child >= 0)
    below = np.where(inner, child, 0)
    first, end, total = _subtree_slots(bvh)
    # A subtree is one leaf where its slots run without a gap: every
    # builder here partitions prim_ids in place, so they always do.
    small = inner & (total[below] <= COUNT_LEAF) & (end[below] - first[below] == total[below])
    child = np.where(small, first[below], child)
    count = np.where(small, total[below], count)
    return CountingBVH(*bvh, leaf_tris, ((child << 32) | count).ravel())


def _subtree_slots(bvh):
    """Each wide node's first and last slot of prim_ids, [first, end), and
    how many primitives lie below it."""
    m = len(bvh.node_child)
    first, end, total = np.zeros(m, np.int64), np.zeros(m, np.int64), np.zeros(m, np.int64)
    levels = list(_levels(bvh)) if m else []           # an empty tree has no root
    for _, rows, _ in reversed(levels):                 # the deepest nodes first
        child, count = bvh.node_child[rows], bvh.node_count[rows]
        inner = (count == 0) & (child >= 0)
        below = np.where(inner, child, 0)
        none = np.iinfo(np.int64).max          # an unused lane holds no slot
        first[rows] = np.where(count > 0, child, np.where(inner, first[below], none)).min(axis=1)
        end[rows] = np.where(count > 0, child + count, np.where(inner, end[below], -1)).max(axis=1)
        total[rows] = np.where(inner, total[below], count).sum(axis=1)
    return first, end, total


def _levels(bvh):
    """The wide nodes level by level from the root's: (depth, rows, lanes),
    lanes being the rows' lanes as indices into the (m * 4,) raveled lane
    arrays.  Flat takes: 2-D fancy indexing with a boolean mask was 2x
    slower (4.2M triangles: 97 against 45 ms for the whole walk)."""
    child = bvh.node_child.ravel()
    inner = (bvh.node_count.ravel() == 0) & (child >= 0)
    rows, d = np.zeros(1, np.int64), 0
    while len(rows):
        lanes = (rows[:, None] * WIDTH + np.arange(WIDTH)).ravel()
        yield d, rows, lanes
        rows = child.take(lanes[inner.take(lanes)])
        d += 1


def _depths(bvh):
    """Each wide node's depth (the root's 0)."""
    depth = np.zeros(len(bvh.node_child), np.int64)
    for d, rows, _ in _levels(bvh):
        depth[rows] = d
    return depth


STATS_BLOCK = 1 << 13      # wide nodes a block (statistics): 256 KB per temporary, in L2


def statistics(bvh, n_prims):
    """Node and leaf counts, depths, leaf sizes, SAH cost and memory of a
    4-wide BVH.  SAH cost: the expected number of node visits (TRAVERSAL_COST
    each) and primitive tests of a random ray that hits the root box, by
    the surface area heuristic (MacDonald & Booth 1990).  A lane is a leaf
    where its count is above 0, an inner node where its count is 0 and
    its child is a row, unused where its child is -1 (collapse_bvh4)."""
    from raytrace.accel.statistics import half_area, leaf_histograms, leaves, memory
    m = len(bvh.node_child)
    out = {"nodes": int(m)}
    if m == 0:
        return out | leaves([], []) | memory(bvh, n_prims)
    box, child, count = bvh.node_box, bvh.node_child, bvh.node_count
    leaf = (count > 0).ravel()
    by_depth = np.zeros(MAX_DEPTH + 2, np.int64)
    for d, _, lanes in _levels(bvh):
        by_depth[d + 1] = np.count_nonzero(leaf.take(lanes))   # a lane is a level deeper
    by_count = np.bincount(count.ravel())
    by_count[0] = 0                       # inner and unused lanes (leaves are never empty)
    # Each lane's box area, half_area's arithmetic on the node array's own
    # rows, (b, 4) per axis, a block of nodes at a time into the same
    # buffers (whole, the temporaries were 6 arrays of 32 bytes a node, 3.2
    # s of the 30M-triangle command, fresh pages here).  Edges in float64
    # (the float32 boxes' products overflow from 1e19 on); fmax makes an
    # unused lane's inf - inf edge 0, so its area is 0 and sums need no
    # mask of used lanes: the leaves' weighted by their counts, the inner
    # nodes' by count 0.
    e = np.empty((3, min(m, STATS_BLOCK), WIDTH))
    area = np.empty(e.shape[1:])
    inner_area = leaf_tests = 0.0
    with np.errstate(invalid="ignore"):          # unused lanes: inf - inf
        for s in range(0, m, STATS_BLOCK):
            rows = slice(s, s + STATS_BLOCK)
            b = len(box[rows])
            for a in range(3):
                np.subtract(box[rows, 3 + a, :], box[rows, a, :], out=e[a, :b], dtype=np.float64)
                np.fmax(e[a, :b], 0.0, out=e[a, :b])
            np.multiply(e[0, :b], e[1, :b], out=area[:b])
            area[:b] += e[1, :b] * e[2, :b]
            area[:b] += e[2, :b] * e[0, :b]
            inner_area += np.dot(area[:b].ravel(), (count[rows] == 0).ravel())
            leaf_tests += np.dot(area[:b].ravel(), count[rows].ravel())
    used = child[0] >= 0
    lo = np.moveaxis(box[0, 0:3, :], 0, 1).astype(np.float64)   # the root's lanes, (4, 3)
    hi = np.moveaxis(box[0, 3:6, :], 0, 1).astype(np.float64)
    root = half_area(lo[used].min(axis=0), hi[used].max(axis=0))
    # A scene beyond float32's range (3.4e38) has boxes to infinity, whose
    # areas say nothing: no SAH cost then.
    if np.isfinite(root):
        visits = 1.0 + inner_area / root if root > 0 else float(m)
        tests = leaf_tests / root if root > 0 else 0.0
        out["sah_cost"] = float(TRAVERSAL_COST * visits + tests)
    return out | leaf_histograms(by_count, by_depth) | memory(bvh, n_prims)


def outline(bvh, depth):
    """(lo, hi, level) of every box down to ``depth`` (--show-structure):
    the root's box is level 0, a node's child lanes one deeper than it."""
    if len(bvh.node_child) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
    used = bvh.node_child >= 0
    node_level = _depths(bvh) + 1                  # level of the lanes a node holds
    lanes = used & (node_level[:, None] <= depth)
    lo = np.moveaxis(bvh.node_box[:, 0:3, :], 1, 2)[lanes]
    hi = np.moveaxis(bvh.node_box[:, 3:6, :], 1, 2)[lanes]
    level = np.broadcast_to(node_level[:, None], lanes.shape)[lanes]
    root_lo, root_hi = lo[level == 1].min(axis=0), hi[level == 1].max(axis=0)
    return (np.vstack([root_lo, lo]), np.vstack([root_hi, hi]), np.concatenate([[0], level]))
