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
``prim_ids[node_start : node_start + node_count]``.  ``collapse_bvh4`` (collapse.py)
then turns it into the 4-wide tree traversal uses (layout.BVH).
"""
import functools

import numba
import numpy as np
from numba import njit

from raytrace.accel.bvh.box8 import HALF, LANES, find_bins, grow_box, grow_centroids
from raytrace.accel.bvh.boxes import box_rows, half_area, outward, round_down, round_up
from raytrace.accel.bvh.layout import (
    BOX,
    BOX_PAD,
    LINK,
    MAX_DEPTH,
    MAX_LEAF,
    N_BINS,
    REFINE,
    SPLIT,
    TRAVERSAL_COST,
)
from raytrace.kernels.jit import BUILD, BUILD_STEP
from raytrace.kernels.threads import run_on_threads

# Row numbers of the builder's scratch rows as array elements: a literal
# argument would compile _corners and _row_area once for each.
_ROW = np.arange(3)


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
    return half_area(x0, y0, z0, x1, y1, z1)


@njit(**dict(BUILD, nogil=True))
def build_bvh_kernel(boxes, prim_ids, start, end, depth, max_leaf, traversal_cost, nodes, first,
                     defer, tasks):
    """The binned-SAH tree over prim_ids[start:end] (reordered in place),
    its root at ``depth``, with a node visit costing ``traversal_cost``
    primitive tests (TRAVERSAL_COST for tracing rays), into rows first,
    first + 1, ... of nodes = (node_lo, node_hi, node_start, node_count)
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
    on the float-to-int arithmetic.  The sweeps skip empty bins.  The same
    tree, built faster (docs/benchmarks.md, "BVH").

    ``boxes``: the primitives' box rows (box_rows; accel/bvh/box8.py).  A
    node's box and centroid box and each bin grow 8 lanes at a time, and
    a primitive's three bins are found together: the same trees, 0.62 ->
    0.40 s for the 1M-triangle teapot on one thread (AVX-512 Xeon)."""
    node_lo, node_hi, node_start, node_count = nodes
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
            bx0, by0, bz0, bx1, by1, bz1 = _corners(grown, _ROW[0])
            cx0, cy0, cz0, cx1, cy1, cz1 = _corners(grown, _ROW[1])
            cx0, cy0, cz0, cx1, cy1, cz1 = (0.5 * cx0, 0.5 * cy0, 0.5 * cz0, 0.5 * cx1,
                                            0.5 * cy1, 0.5 * cz1)
            # A parent's largest magnitude is at least its children's, so padded
            # children stay inside padded parents (rounding is monotonic).
            pad = BOX_PAD * max(abs(bx0), abs(by0), abs(bz0), abs(bx1), abs(by1), abs(bz1))
            node_lo[node, 0] = round_down(bx0 - pad)
            node_lo[node, 1] = round_down(by0 - pad)
            node_lo[node, 2] = round_down(bz0 - pad)
            node_hi[node, 0] = round_up(bx1 + pad)
            node_hi[node, 1] = round_up(by1 + pad)
            node_hi[node, 2] = round_up(bz1 + pad)

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
                                cost_right = m * _row_area(grown, _ROW[2])
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
                            cost = m * _row_area(grown, _ROW[2]) + right_cost[b]
                            if cost < best_cost:
                                best_cost = cost
                                best_axis = a
                                best_bin = b

                    # Leaf or split (costs scaled by the node's half area, so a
                    # zero-area node compares without dividing by zero).
                    area = half_area(bx0, by0, bz0, bx1, by1, bz1)
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
                                     float(traversal_cost), nodes, 0, 0, _NO_TASKS)
    return tuple(a[:n_nodes] for a in nodes) + (prim_ids,)


_NO_TASKS = np.empty((0, 4), np.int64)


# ---------------------------------------------------------------- parallel build
#
# The binned-SAH BVH built on every thread: the serial builder's tree, so
# the same 4-wide tree, statistics and images.
#
# The top of the tree is built first, by the serial loop, until nodes hold
# at most n / SPLIT primitives; those are left as tasks.  A task's subtree
# owns its range [s, e) of prim_ids, so the tasks are built at once on
# Python threads (the builder releases the GIL), each by the same loop.
# Nothing is copied afterwards (a copy into depth-first order touched fresh
# pages, which cost more here than a second thread gained, docs/design.md):
# the collapse into the 4-wide tree follows the top's first-child links
# explicitly (``links``), and every subtree is depth-first within its rows.
#
# The rows: the top's from row 0, then a run for each thread, in which its
# tasks' subtrees follow one another.  A subtree over e - s primitives has
# at most 2 (e - s) - 1 nodes, so a run twice its thread's primitives long
# never meets the next.  It fills about half of that; the rest is never
# written and costs no memory, but for the 2 MB page (NumPy's huge pages)
# at each end of the rows written, resident whole: a run per task, not
# per thread, held several times as many of them.
#
# Tasks go to threads largest first, each to the least loaded (LPT
# scheduling).  Where that leaves one thread much more work than the mean
# (7 near-equal subtrees on 2 threads: 3 against 4), the largest task's root is split first, serially
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
    # The top's rows hold its nodes and placeholders, at most the serial
    # tree's 2 n - 1, and three a split task (its root, two placeholders);
    # the threads' runs 2 n together.
    rows = max(2 * n - 1, 1) + 3 * refine + 2 * n
    nodes = (np.empty((rows, 3), BOX), np.empty((rows, 3), BOX), np.empty(rows, LINK),
             np.empty(rows, LINK))
    node_count = nodes[3]
    prim_ids = np.arange(n)
    tasks = np.empty((n, 4), np.int64)
    cost = float(traversal_cost)
    top, _, n_tasks = build_bvh_kernel(boxes, prim_ids, 0, n, 0, max_leaf, cost, nodes, 0,
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
        split_to[row] = top
        top, _, n_more = build_bvh_kernel(boxes, prim_ids, s, e, depth, max_leaf, cost, nodes,
                                          top, e - s - 1, more)
        tasks = np.concatenate([np.delete(tasks, k, axis=0), more[:n_more]])
        queues = _plan(tasks, threads)
        refine -= 1
    n_tasks = len(tasks)
    firsts = np.empty(n_tasks, np.int64)    # each task's root row
    ends = np.empty(n_tasks, np.int64)      # and the row after its subtree
    no_tasks = tasks[:0]

    def work(queue, row):
        for k in queue:
            s, e, depth = (int(x) for x in tasks[k, 1:])
            firsts[k] = row
            row = ends[k] = build_bvh_kernel(boxes, prim_ids, s, e, depth, max_leaf, cost, nodes,
                                             row, 0, no_tasks)[0]
    runs = [2 * int((tasks[q, 2] - tasks[q, 1]).sum()) for q in queues]
    run_on_threads([functools.partial(work, q, first)
                    for q, first in zip(queues, (top + np.cumsum([0] + runs[:-1])).tolist())])
    # A top node's children are rows of the top, or placeholders (count -1)
    # whose subtrees' roots are in the runs: link past the placeholders.
    root_of = dict(zip(tasks[:, 0].tolist(), firsts.tolist())) | split_to
    top_first = np.arange(1, top + 1)
    inner = np.flatnonzero(node_count[:top] == 0)
    for r in inner.tolist():
        top_first[r] = root_of.get(r + 1, r + 1)
        nodes[2][r] = root_of.get(int(nodes[2][r]), int(nodes[2][r]))
    n_inner = len(inner) + sum(int(np.count_nonzero(node_count[first:end] == 0))
                               for first, end in zip(firsts.tolist(), ends.tolist()))
    return (*nodes, prim_ids, (0, top, top_first, n_inner))


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
