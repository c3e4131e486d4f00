"""kd-tree build invariants; its answers against brute force are covered by
every test that runs over tests/structures.py."""
import numpy as np
import pytest

from raytrace.accel.grid.build import grid_eps
from raytrace.accel.kdtree.build import LEAF, build_kdtree


def leaves_with_boxes(tree):
    """(leaf node, box lo, box hi) of every leaf, walking from the root."""
    out = []
    stack = [(0, tree.lo.copy(), tree.hi.copy())]
    while stack:
        node, lo, hi = stack.pop()
        a = tree.node_axis[node]
        if a == LEAF:
            out.append((node, lo, hi))
            continue
        s = tree.node_split[node]
        assert lo[a] <= s <= hi[a]
        below_hi, above_lo = hi.copy(), lo.copy()
        below_hi[a] = s
        above_lo[a] = s
        assert tree.node_index[node] > node + 1       # depth-first: the below child is next
        stack.append((node + 1, lo, below_hi))
        stack.append((tree.node_index[node], above_lo, hi))
    return out


@pytest.mark.parametrize("seed, n, size", [(0, 1, 0.1), (1, 50, 0.05), (2, 2000, 0.01),
                                           (3, 300, 0.5)])
def test_every_primitive_is_in_each_leaf_its_widened_box_touches(seed, n, size):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, (n, 3))
    lo, hi = c - rng.uniform(0, size, (n, 3)), c + rng.uniform(0, size, (n, 3))
    tree = build_kdtree(lo, hi)
    eps = grid_eps(tree.lo, tree.hi)
    leaves = leaves_with_boxes(tree)
    assert len(leaves) == int((tree.node_axis == LEAF).sum())
    seen = np.zeros(n, bool)
    for node, blo, bhi in leaves:
        listed = set(tree.prim_list[tree.node_index[node]:
                                    tree.node_index[node] + tree.node_count[node]].tolist())
        touching = np.flatnonzero(((lo - eps) <= bhi).all(axis=1) & ((hi + eps) >= blo).all(axis=1))
        assert set(touching.tolist()) <= listed
        seen[list(listed)] = True
    assert seen.all()
    assert (tree.lo < lo.min(axis=0)).all() and (tree.hi > hi.max(axis=0)).all()


def test_empty_and_coincident_boxes():
    empty = build_kdtree(np.zeros((0, 3)), np.zeros((0, 3)))
    assert len(empty.node_axis) == 0
    same = build_kdtree(np.zeros((40, 3)), np.zeros((40, 3)))   # no plane separates them
    leaf = same.node_axis == LEAF
    assert (same.node_count[~leaf] == 0).all()
    assert sorted(set(same.prim_list.tolist())) == list(range(40))


@pytest.mark.parametrize("seed, n, size", [(4, 40, 0.6), (5, 400, 0.2)])
def test_clipped_triangles_are_in_every_leaf_they_cross(seed, n, size):
    """Perfect splits: a triangle is listed in each leaf whose widened box
    holds a point of it (points sampled over each triangle), and clipping
    lists long triangles in fewer leaves than their boxes touch."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, (n, 1, 3))
    tri = c + rng.uniform(-size, size, (n, 3, 3))
    v0, v1, v2 = tri[:, 0], tri[:, 1], tri[:, 2]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    tree = build_kdtree(lo, hi, triangles=(v0, v1, v2))
    eps = grid_eps(tree.lo, tree.hi)
    w = np.array([(i / 12, j / 12) for i in range(13) for j in range(13 - i)])
    points = (v0[:, None] * (1 - w.sum(axis=1))[None, :, None] + v1[:, None] * w[None, :, :1]
              + v2[:, None] * w[None, :, 1:])                        # (n, samples, 3)
    refs = 0
    for node, blo, bhi in leaves_with_boxes(tree):
        listed = set(tree.prim_list[tree.node_index[node]:
                                    tree.node_index[node] + tree.node_count[node]].tolist())
        inside = ((points >= blo - eps) & (points <= bhi + eps)).all(axis=2).any(axis=1)
        assert set(np.flatnonzero(inside).tolist()) <= listed
        refs += len(listed)
    boxes_only = build_kdtree(lo, hi)
    assert refs < len(boxes_only.prim_list)
