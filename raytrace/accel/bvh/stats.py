"""The BVH's statistics and its outline for --show-structure, walked level
by level."""

import numpy as np

from raytrace.accel.bvh.layout import MAX_DEPTH, TRAVERSAL_COST, WIDTH


def levels(bvh):
    """The wide nodes level by level from the root's: (depth, rows, lanes),
    lanes being the rows' lanes as indices into the (m * 4,) raveled lane
    arrays.  Flat takes, not 2-D fancy indexing with a boolean mask,
    which is slower (docs/benchmarks.md, "BVH")."""
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
    for d, rows, _ in levels(bvh):
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
    for d, _, lanes in levels(bvh):
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
            # Sums of products, not np.dot: a threaded BLAS call leaves
            # OpenBLAS's threads spinning, which took the next render's cores.
            weights = area[:b].ravel()
            inner_area += float(weights[(count[rows] == 0).ravel()].sum())
            leaf_tests += float((weights * count[rows].ravel()).sum())
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
