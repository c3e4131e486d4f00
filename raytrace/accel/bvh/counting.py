"""The layout counting and listing every hit read (layout.CountingBVH): a
tree built for counting, its lanes packed."""

import numpy as np

from raytrace.accel.bvh.layout import COUNT_LEAF, CountingBVH
from raytrace.accel.bvh.stats import levels


def counting_copy(bvh):
    """The CountingBVH over tree ``bvh``: its lanes packed (8 bytes a
    lane)."""
    child, count = bvh.node_child, bvh.node_count
    inner = (count == 0) & (child >= 0)
    below = np.where(inner, child, 0)
    first, end, total = _subtree_slots(bvh)
    # A subtree is one leaf where its slots run without a gap: every
    # builder here partitions prim_ids in place, so they always do.
    small = inner & (total[below] <= COUNT_LEAF) & (end[below] - first[below] == total[below])
    child = np.where(small, first[below], child)
    count = np.where(small, total[below], count)
    return CountingBVH(*bvh, ((child << 32) | count).ravel())


def _subtree_slots(bvh):
    """Each wide node's first and last slot of prim_ids, [first, end), and
    how many primitives lie below it."""
    m = len(bvh.node_child)
    first, end, total = np.zeros(m, np.int64), np.zeros(m, np.int64), np.zeros(m, np.int64)
    by_level = list(levels(bvh)) if m else []         # an empty tree has no root
    for _, rows, _ in reversed(by_level):               # the deepest nodes first
        child, count = bvh.node_child[rows], bvh.node_count[rows]
        inner = (count == 0) & (child >= 0)
        below = np.where(inner, child, 0)
        none = np.iinfo(np.int64).max          # an unused lane holds no slot
        first[rows] = np.where(count > 0, child, np.where(inner, first[below], none)).min(axis=1)
        end[rows] = np.where(count > 0, child + count, np.where(inner, end[below], -1)).max(axis=1)
        total[rows] = np.where(inner, total[below], count).sum(axis=1)
    return first, end, total
