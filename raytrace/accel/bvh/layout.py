"""The BVH's layout, the contract between its builders and its traversals,
and the constants the builders are tuned by."""
from collections import namedtuple

import numpy as np

# The layout traversal reads (raytrace/accel/bvh/traverse.py), 4 children per
# node: node_box (m, 6, 4) float32 child boxes, rows lo x, y, z, hi x, y, z,
# a lane per child; node_count (m, 4) > 0 makes a lane a leaf covering
# prim_ids[node_child : node_child + node_count], 0 an inner child, node
# node_child (or an unused lane, whose box is +inf).  prim_ids: unified ids.
# box_bound: the largest magnitude of a box coordinate (inf past float32's
# range), which bounds the float32 box test's distances (accel/bvh/traverse.py).
# lane_entry (m, 4) int64: what a traversal pushes for each lane, from
# node_child and node_count (lane_entries): an inner lane its node, a leaf
# ~(first slot << 32 | count), so an entered lane is one load, and a leaf
# popped from the stack names its slots without another.
# leaf_tris, (9, len(prim_ids) + 3) float64: column k the corners of the
# triangle in slot k of prim_ids, row 3 * corner + axis; NaN where a slot
# holds a sphere, and in the 3 columns past the end, so a leaf loads 4
# columns at a time (simd.leaf_hits, simd.crossing_mask) where it
# gathered 9 coordinates from 3 arrays through prim_ids for each triangle.
BVH = namedtuple("BVH", ["node_box", "node_child", "node_count", "prim_ids", "box_bound",
                         "lane_entry", "leaf_tris"])


def lane_entries(node_child, node_count):
    """The BVH's lane_entry words.  A slot below 2^31 and a count below 2^32
    (any mesh that fits in memory) keep every leaf's word above
    traverse._DONE, -2^63."""
    leaf = ~((node_child << 32) | node_count)
    return np.where(node_count > 0, leaf, node_child).astype(np.int64)


# The layout counting and listing every hit read (for_counting): the
# fields of a BVH of its own, built for counting (COUNT_TRAVERSAL_COST), and
# - lanes, (m * 4,) int64: each lane's node_child << 32 | node_count, one
#   load where a lane took two (a leaf's is its queue entry as it stands),
#   where an inner lane whose subtree holds at most COUNT_LEAF primitives
#   in contiguous slots (every builder's subtrees do) is a leaf over them,
#   so counting tests them at once instead of visiting its nodes.
CountingBVH = namedtuple("CountingBVH", BVH._fields + ("lanes",))
# One 8-lane crossing test (simd.CROSSING_LANES): 6% faster
# counts than the tree's own leaves, 10 and 16 no faster (docs/design.md).
COUNT_LEAF = 8
# The counting tree's SAH weighs a node visit as 4 triangle tests, where a
# tree for tracing weighs it as 2 (TRAVERSAL_COST): its leaves hold up to
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
# SAH may still make a smaller node a leaf.  2, 4 and 8 trace alike fast
# (docs/benchmarks.md, "BVH").  --leaf-size sets it.
MAX_LEAF = 4
# Cost of one node visit (two child box tests) relative to one primitive
# test, in the SAH: C = TRAVERSAL_COST + (A_L N_L + A_R N_R) / A.  2 since
# leaves test their triangles 4 at a time (simd.leaf_hits), so a triangle
# test costs less against a node visit than the 1 the scalar test was
# weighed at: fuller leaves, fewer nodes.  One thread, against 1: 5-15%
# faster on random, shuffled and bounce rays at 118k and on every ray set at
# 1M, 3-30% on four meshes no bench had (a triangle soup, a terrain, two
# other tools' files); 1k camera and shadow packets 2-7% slower
# (docs/benchmarks.md, "Leaves tested 4 triangles at a time").
TRAVERSAL_COST = 2.0
# A node visit against one sphere test: spheres are tested one by one (as
# triangles were at cost 1), so a scene of spheres is built at 1, a mixed
# one at the harmonic mean over its primitives (build.scene_traversal_cost).  At
# 2, whitted.toml's two spheres shared a leaf: 1.74 M -> 2.52 M primitive
# tests a frame (docs/benchmarks.md).
SPHERE_TRAVERSAL_COST = 1.0
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
# subtrees balance the threads better (docs/benchmarks.md, "BVH").
SPLIT = 4
# At most this many subtrees split again to even out the threads' shares.
REFINE = 4
