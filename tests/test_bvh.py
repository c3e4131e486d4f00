"""BVH: build invariants, and differential tests against brute force.

The BVH must give exactly (==) the brute-force answer: same t, primitive id
and barycentrics for closest hits, same verdict for shadow rays.
"""
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from raytrace.accel.bvh.boxes import box_rows, outward
from raytrace.accel.bvh.collapse import collapse_bvh4
from raytrace.accel.bvh.counting import counting_copy
from raytrace.accel.bvh.layout import BOX, LINK, MAX_DEPTH, WIDTH
from raytrace.accel.bvh.sah import build_bvh, build_bvh_kernel, build_bvh_parallel
from raytrace.accel.registry import build_structure as build_accel
from raytrace.accel.registry import get as get_structure
from raytrace.kernels.buffers import INDEX, prim_bounds
from raytrace.kernels.cast import COLUMNS, cast_closest, cast_counts, cast_occluded, ray_scene
from raytrace.kernels.counters import BAD_RAYS, BOX_TESTS, NODES_VISITED, PRIM_HITS, PRIM_TESTS
from raytrace.scene.flatten import flatten
from raytrace.scene.model import Camera, Mesh, Plane, Scene, Sphere

PROPERTY = settings(derandomize=True, max_examples=25, deadline=None)


# ---------------------------------------------------------------- helpers

def make_scene(tris=None, spheres=(), planes=()):
    """Geometry and object ranges through the real loader (flatten)."""
    objs = []
    if tris is not None and len(tris):
        tris = np.asarray(tris, float).reshape(-1, 3, 3)
        objs.append(Mesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3)))
    objs += [Sphere(tuple(c), float(r)) for c, r in spheres]
    objs += [Plane(tuple(p), tuple(n)) for p, n in planes]
    geo, ranges, _ = flatten(Scene("t", Camera((0, 0, 5), (0, 0, 0)), objs))
    return geo, ranges


def run_kernel(kernel, geo, acc, o, d, t_max, *out):
    """Call a query kernel (kernels/cast.py) on rays o, d with t_min 0;
    returns the summed counters."""
    cnt = np.zeros((4, COLUMNS), np.int64)
    kernel(geo, acc, np.ascontiguousarray(o, float), np.ascontiguousarray(d, float),
           np.zeros(len(o)), np.ascontiguousarray(t_max, float), *out, cnt, np.zeros(1, np.int64))
    return cnt.sum(axis=0)


def _on_scene(kernel):
    """A ray query's kernel, which takes the scene packed, on geo, acc."""
    return lambda geo, acc, *rest: kernel(ray_scene(geo, acc), *rest)


def closest(geo, acc, o, d, t_max=None):
    n = len(o)
    out = (np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n))
    return out, run_kernel(_on_scene(cast_closest), geo, acc, o, d,
                           np.full(n, np.inf) if t_max is None else t_max, *out)


def occluded(geo, acc, o, d, t_max):
    hit = np.empty(len(o), np.bool_)
    return hit, run_kernel(_on_scene(cast_occluded), geo, acc, o, d, t_max, hit)


def counts(geo, acc, o, d, t_max):
    """Every crossing along each ray (count_intersections' kernel)."""
    out = np.empty(len(o), np.int64)
    return out, run_kernel(_on_scene(cast_counts), geo, acc, o, d, t_max, out)


def assert_same_as_brute(geo, ranges, o, d, t_max_occ, name="bvh", **build_opts):
    brute, _ = build_accel("none", geo, ranges)
    bvh, _ = build_accel(name, geo, ranges, **build_opts)
    (t0, p0, u0, v0), _ = closest(geo, brute, o, d)
    (t1, p1, u1, v1), _ = closest(geo, bvh, o, d)
    bad = ~((t0 == t1) & (p0 == p1) & (u0 == u1) & (v0 == v1))
    assert not bad.any(), (
        f"{bad.sum()} closest hits differ, first ray {np.argmax(bad)}: "
        f"brute {(t0[bad][0], p0[bad][0])} bvh {(t1[bad][0], p1[bad][0])}")
    # Same with a finite t_max cutting some hits off.
    (t0, p0, u0, v0), _ = closest(geo, brute, o, d, t_max_occ)
    (t1, p1, u1, v1), _ = closest(geo, bvh, o, d, t_max_occ)
    assert np.array_equal(t0, t1) and np.array_equal(p0, p1)
    assert np.array_equal(u0, u1) and np.array_equal(v0, v1)
    h0, _ = occluded(geo, brute, o, d, t_max_occ)
    h1, _ = occluded(geo, bvh, o, d, t_max_occ)
    assert np.array_equal(h0, h1), f"{(h0 != h1).sum()} shadow rays differ"
    # Every hit counted, on the layout that counts (the BVH's: a tree built
    # for counting, its triangles copied in leaf order, tested 8 at a
    # time), and for the BVH on this builder's own tree copied the same way.
    layouts = [get_structure(name).counting_layout(bvh, geo)]
    if name == "bvh":
        layouts.append(counting_copy(bvh))
    for counting, t_max in itertools.product(layouts, (np.full(len(o), np.inf), t_max_occ)):
        (c0, k0), (c1, k1) = counts(geo, brute, o, d, t_max), counts(geo, counting, o, d, t_max)
        assert np.array_equal(c0, c1), f"{(c0 != c1).sum()} counts differ"
        assert k0[PRIM_HITS] == k1[PRIM_HITS]


def random_dirs(rng, n):
    """Random directions, a third of them with components exactly 0.0 or -0.0
    (axis-parallel rays: 1/0 = +-inf in the slab test)."""
    d = rng.standard_normal((n, 3))
    k = n // 3
    axis = rng.integers(0, 3, k)
    zero = np.where(rng.random(k) < 0.5, 0.0, -0.0)
    d[np.arange(k), axis] = zero
    m = k // 2  # of those, half are parallel to a coordinate axis
    other = (axis[:m] + 1 + rng.integers(0, 2, m)) % 3
    d[np.arange(m), other] = np.where(rng.random(m) < 0.5, 0.0, -0.0)
    return d


def random_soup(rng, n, size):
    c = rng.random((n, 1, 3)) * 2 - 1
    return c + size * rng.standard_normal((n, 3, 3))


def tree_check(lo, hi, tree):
    """Structural invariants of a flattened BVH over boxes lo, hi."""
    node_lo, node_hi, node_start, node_count, prim_ids = tree
    n, m = len(lo), len(node_start)
    for a, dtype in ((node_start, LINK), (node_count, LINK), (prim_ids, INDEX)):
        assert a.dtype == dtype and a.ndim == 1 and a.flags.c_contiguous
    for a in (node_lo, node_hi):
        assert a.dtype == BOX and a.shape == (m, 3) and a.flags.c_contiguous
    assert len(node_count) == m and len(prim_ids) == n
    assert m <= max(2 * n - 1, 0)
    if n == 0:
        assert m == 0
        return 0
    seen_node = np.zeros(m, int)
    seen_prim = np.zeros(n, int)
    stack = [(0, 0)]
    max_depth = 0
    while stack:
        i, depth = stack.pop()
        seen_node[i] += 1
        max_depth = max(max_depth, depth)
        if node_count[i] > 0:
            s, c = node_start[i], node_count[i]
            ids = prim_ids[s:s + c]
            seen_prim[ids] += 1
            # leaf box contains its primitives' boxes
            assert np.all(node_lo[i] <= lo[ids]) and np.all(node_hi[i] >= hi[ids])
        else:
            assert node_count[i] == 0
            kids = (i + 1, node_start[i])
            assert i + 1 < kids[1] < m
            for k in kids:  # children inside the parent
                assert np.all(node_lo[i] <= node_lo[k]) and np.all(node_hi[i] >= node_hi[k])
                stack.append((k, depth + 1))
    assert np.all(seen_node == 1), "every node reachable exactly once"
    assert np.all(seen_prim == 1), "every primitive in exactly one leaf"
    # leaves partition prim_ids: ranges are disjoint and cover 0..n-1
    leaf = node_count > 0
    order = np.argsort(node_start[leaf])
    starts, counts = node_start[leaf][order], node_count[leaf][order]
    assert starts[0] == 0 and np.all(starts[1:] == starts[:-1] + counts[:-1])
    assert starts[-1] + counts[-1] == n
    assert max_depth <= MAX_DEPTH
    return max_depth


def wide_check(lo, hi, node_box, node_child, node_count, prim_ids):
    """Invariants of the 4-wide tree traversal uses (collapse_bvh4)."""
    n, m = len(lo), len(node_box)
    # float32, rounded outwards: the leaf and child checks below compare
    # them with the float64 boxes exactly.
    assert node_box.dtype == BOX and node_box.shape == (m, 6, 4)
    for a in (node_child, node_count):
        assert a.dtype == INDEX and a.shape == (m, 4) and a.flags.c_contiguous
    assert node_box.flags.c_contiguous and len(prim_ids) == n
    if n == 0:
        assert m == 0
        return
    seen_node = np.zeros(m, int)
    seen_prim = np.zeros(n, int)
    leaves = []
    stack = [(0, None, 0)]  # node, the parent lane's box (lo, hi), depth
    while stack:
        i, outer, depth = stack.pop()
        assert depth <= MAX_DEPTH
        seen_node[i] += 1
        used = 0
        for j in range(4):
            blo, bhi = node_box[i, :3, j], node_box[i, 3:, j]
            if node_count[i, j] == 0 and node_child[i, j] < 0:
                # unused lane: a box no ray can enter
                assert np.all(blo == np.inf) and np.all(bhi == np.inf)
                continue
            used += 1
            if outer is not None:  # children inside the parent
                assert np.all(outer[0] <= blo) and np.all(outer[1] >= bhi)
            if node_count[i, j] > 0:
                s, c = node_child[i, j], node_count[i, j]
                ids = prim_ids[s:s + c]
                seen_prim[ids] += 1
                leaves.append((s, c))
                assert np.all(blo <= lo[ids]) and np.all(bhi >= hi[ids])
            else:
                assert i < node_child[i, j] < m  # numbered depth-first
                stack.append((node_child[i, j], (blo, bhi), depth + 1))
        # a wide node has 2-4 children, unless the whole tree is one leaf
        assert used >= 2 or (m == 1 and used == 1)
    assert np.all(seen_node == 1), "every node reachable exactly once"
    assert np.all(seen_prim == 1), "every primitive in exactly one leaf"
    starts, counts = np.array(sorted(leaves)).T
    assert starts[0] == 0 and np.all(starts[1:] == starts[:-1] + counts[:-1])
    assert starts[-1] + counts[-1] == n


def wide_of(lo, hi):
    node_lo, node_hi, node_start, node_count, prim_ids = tree = build_bvh(lo, hi)
    tree_check(lo, hi, tree)
    wide = collapse_bvh4(node_lo, node_hi, node_start, node_count)
    wide_check(lo, hi, *wide, prim_ids)
    return tree, wide


def boxes_of(tris):
    return tris.min(axis=1), tris.max(axis=1)


# ---------------------------------------------------------------- build

def test_build_empty():
    z = np.zeros((0, 3))
    tree, wide = wide_of(z, z)
    assert all(len(a) == 0 for a in tree + wide)


def test_build_single():
    lo, hi = np.array([[0.0, 1, 2]]), np.array([[1.0, 2, 3]])
    tree, (node_box, node_child, count4) = wide_of(lo, hi)
    node_lo, node_hi, node_start, node_count, prim_ids = tree
    assert node_count.tolist() == [1] and node_start.tolist() == [0] and prim_ids.tolist() == [0]
    # one wide node whose first lane is the leaf
    assert count4.tolist() == [[1, 0, 0, 0]] and node_child.tolist() == [[0, -1, -1, -1]]
    # The binary box rounded outwards to the next float32s, not to the nearest.
    wide_lo, wide_hi = node_box[0, :3, 0].astype(np.float64), node_box[0, 3:, 0].astype(np.float64)
    assert np.all(wide_lo <= node_lo[0]) and np.all(wide_hi >= node_hi[0])
    assert np.array_equal(np.nextafter(node_box[0, :3, 0], np.float32(np.inf)) > node_lo[0], [True] * 3)
    assert np.array_equal(np.nextafter(node_box[0, 3:, 0], np.float32(-np.inf)) < node_hi[0], [True] * 3)
    # The box widened by the builder's tiny pad (1e-9 of 3), then out to the
    # next float32s.
    assert node_lo.dtype == node_hi.dtype == BOX
    padded_lo, padded_hi = lo - 3e-9, hi + 3e-9
    assert np.all(node_lo <= padded_lo)
    assert np.all(node_lo >= padded_lo - np.spacing(np.abs(padded_lo).astype(BOX)))
    assert np.all(node_hi >= padded_hi)
    assert np.all(node_hi <= padded_hi + np.spacing(np.abs(padded_hi).astype(BOX)))


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 400),
       size=st.sampled_from([0.0, 1e-3, 0.05, 0.5]))
@PROPERTY
def test_build_invariants(seed, n, size):
    rng = np.random.default_rng(seed)
    lo, hi = boxes_of(random_soup(rng, n, size))
    wide_of(lo, hi)


def test_collapse_keeps_boxes_and_shrinks_tree():
    """Every box of the wide tree is a box of the binary tree rounded
    outwards to float32 (so it culls no ray the binary tree keeps), in about
    a third as many nodes."""
    lo, hi = boxes_of(random_soup(np.random.default_rng(12), 2000, 0.02))
    (node_lo, node_hi, node_start, node_count, _), (node_box, node_child, count4) = wide_of(lo, hi)
    used = ~np.isinf(node_box[:, 0, :])
    lanes = np.concatenate([node_box[:, :3, :].transpose(0, 2, 1)[used],
                            node_box[:, 3:, :].transpose(0, 2, 1)[used]], axis=1)
    lo32, hi32 = node_lo.astype(np.float32), node_hi.astype(np.float32)
    lo32 = np.where(lo32 > node_lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32 < node_hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    binary = np.concatenate([lo32, hi32], axis=1)[1:]   # every node but the root
    assert set(map(tuple, lanes)) <= set(map(tuple, binary))
    # a lane per wide node but the root, and one per binary leaf
    assert used.sum() == len(node_box) - 1 + (node_count > 0).sum()
    assert len(node_box) < 0.4 * len(node_start)


def test_build_coincident_centroids():
    """All centroids equal: no plane separates them, the median split must."""
    lo = np.tile([[-1.0, -1, -1]], (100, 1))
    hi = np.tile([[1.0, 1, 1]], (100, 1))
    lo[::2] *= 0.5
    hi[::2] *= 0.5
    tree, _ = wide_of(lo, hi)
    assert tree[3].max() <= 4, "median fallback keeps splitting to small leaves"


def test_build_depth_capped():
    """Boxes at exponentially growing distances make SAH trees a chain;
    depth stays within the traversal stack, and traversal stays exact.
    The chain's boxes lie within float32's range (3^-75 .. 3^75, each a
    tenth of its distance long), so the float32 tree still tells them
    apart; the triangles reach 3^199, beyond it, where the tree's boxes
    run to infinity and culling weakens, and the hits stay exact."""
    s = 3.0 ** np.arange(-75, 75)
    lo = np.stack([s, np.zeros_like(s), np.zeros_like(s)], axis=1)
    hi = lo + 0.1 * s[:, None]
    depth = tree_check(lo, hi, build_bvh(lo, hi))
    assert depth == MAX_DEPTH
    wide_of(lo, hi)
    x = 3.0 ** np.arange(200)
    tri = np.array([[0.0, -1, -1], [0.0, 1, -1], [0.5, 0, 1]])
    geo, ranges = make_scene(x[:, None, None] * [1, 0, 0] + tri)
    rng = np.random.default_rng(9)
    o = np.column_stack([-np.ones(300), rng.random((300, 2)) - 0.5])
    d = np.tile([1.0, 0.0, 0.0], (300, 1))
    d[::2, 1:] = rng.standard_normal((150, 2)) * 1e-3
    assert_same_as_brute(geo, ranges, o, d, rng.random(300) * 1e3)


def test_build_accel_fields():
    rng = np.random.default_rng(1)
    spheres = [((0, 0, 0), 0.3), ((1, 1, 1), 0.2)]
    geo, ranges = make_scene(random_soup(rng, 50, 0.1), spheres=spheres)
    acc, seconds = build_accel("bvh", geo, ranges)
    lo, hi = prim_bounds(geo)
    wide_check(lo, hi, acc.node_box, acc.node_child, acc.node_count, acc.prim_ids)
    assert sorted(acc.prim_ids) == list(range(52))  # unified ids include spheres
    assert seconds >= 0


@pytest.mark.parametrize("bvh_build", ["sah", "median", "lbvh"])
@pytest.mark.parametrize("n_tris", [5, 50, 700])
def test_leaf_triangles_lane_entries_and_counting_lanes(n_tris, bvh_build):
    """Any builder's tree: column k of leaf_tris holds slot k's triangle
    (NaN for a sphere's slot and the 3 columns of padding); a lane_entry
    word is the lane's child node, or a leaf's first slot and count.
    counting_copy: each lane word unpacks to the lane's child and count,
    unused lanes' -1 child included, but for an inner lane whose subtree
    holds at most COUNT_LEAF primitives, which is a leaf over exactly that
    subtree's slots."""
    from raytrace.accel.bvh.layout import COUNT_LEAF
    rng = np.random.default_rng(2)
    geo, ranges = make_scene(random_soup(rng, n_tris, 0.1), spheres=[((0, 0, 0), 0.3)])
    acc, _ = build_accel("bvh", geo, ranges, bvh_build=bvh_build)
    c = counting_copy(acc)
    assert c.prim_ids is acc.prim_ids and c.node_box is acc.node_box
    assert c.leaf_tris is acc.leaf_tris
    leaf = acc.node_count > 0
    word = ~acc.lane_entry[leaf]
    assert np.array_equal(word >> 32, acc.node_child[leaf])
    assert np.array_equal(word & 0xFFFFFFFF, acc.node_count[leaf])
    assert np.array_equal(acc.lane_entry[~leaf], acc.node_child[~leaf])
    tri = acc.prim_ids < n_tris
    for corner, v in enumerate((geo.tri_v0, geo.tri_v1, geo.tri_v2)):
        rows = c.leaf_tris[3 * corner:3 * corner + 3]
        assert np.array_equal(rows[:, :-3][:, tri], v[acc.prim_ids[tri]].T)
    assert np.isnan(c.leaf_tris[:, :-3][:, ~tri]).all() and np.isnan(c.leaf_tris[:, -3:]).all()

    def slots(node):
        """The slots of the leaves under node, in the tree as built."""
        out = []
        for child, count in zip(acc.node_child[node], acc.node_count[node]):
            out += list(range(child, child + count)) if count else (
                slots(child) if child >= 0 else [])
        return out

    child, count = c.lanes >> 32, c.lanes & 0xFFFFFFFF
    kept = (acc.node_count.ravel() > 0) | (acc.node_child.ravel() < 0)
    assert np.array_equal(child[kept], acc.node_child.ravel()[kept])
    assert np.array_equal(count[kept], acc.node_count.ravel()[kept])
    merged = 0
    for lane in np.flatnonzero(~kept):
        below = slots(acc.node_child.ravel()[lane])
        if len(below) <= COUNT_LEAF:
            merged += 1
            assert list(range(child[lane], child[lane] + count[lane])) == sorted(below)
        else:
            assert child[lane] == acc.node_child.ravel()[lane] and count[lane] == 0
    # The median split fills its leaves (3 or 4 each) and every lane, so
    # its smallest inner lanes hold 10 or more primitives: none is merged.
    assert merged > 0 or n_tris < 50 or bvh_build == "median"
    assert (acc.node_child == -1).any() or bvh_build == "median"


def test_counting_layout_is_a_tree_built_for_counting():
    """for_counting counts on a tree of its own (COUNT_LEAF, COUNT_TRAVERSAL
    _COST), not on the tracing tree it is given: fewer, fuller leaves."""
    from raytrace.accel.bvh.build import build
    from raytrace.accel.bvh.layout import COUNT_LEAF, COUNT_TRAVERSAL_COST
    rng = np.random.default_rng(4)
    geo, ranges = make_scene(random_soup(rng, 2000, 0.05))
    tracing, _ = build_accel("bvh", geo, ranges)
    c = get_structure("bvh").counting_layout(tracing, geo)
    own = build(geo, ranges, leaf_size=COUNT_LEAF, traversal_cost=COUNT_TRAVERSAL_COST)
    for got, want in zip(c, counting_copy(own)):
        assert np.array_equal(got, want, equal_nan=True)
    assert len(c.node_box) < len(tracing.node_box)


# A chain node's lanes for rounds of 2 and 3 nodes (kernels/bvh.ROUND), so
# that each round leaves 3 * ROUND inner nodes on the stack (a simulation
# of the traversal's order found these the worst of the chain patterns).
# Two a round: twig, twig, the next chain node, a fan: the fan (on top) and
# the next chain node are popped together, and the fan's 4 twigs and the
# chain node's 2 stay below the next round's pushes.  Three a round: fan,
# the next chain node, fan, fan: the chain node and two fans are popped
# together and the next chain node is third from the top.
PILE_UP = {2: "ttcf", 3: "fcff"}


def _rounds_that_pile_up(levels, pattern):
    """A 4-wide tree (node_child, node_count rows): a chain of ``levels``
    nodes, each with lanes as ``pattern`` says (t a twig: a node with one
    leaf of one primitive; f a fan: a node of 4 twigs; c the next chain
    node), the last of 4 twigs.  Returns the rows and the number of
    leaves."""
    child, count = [], []
    leaves = 0

    def node():
        child.append([-1] * WIDTH)
        count.append([0] * WIDTH)
        return len(child) - 1

    def twig():
        nonlocal leaves
        t = node()
        child[t][0], count[t][0] = leaves, 1
        leaves += 1
        return t

    def fan():
        f = node()
        for lane in range(WIDTH):
            child[f][lane] = twig()
        return f

    chain = node()
    for level in range(levels):
        if level == levels - 1:
            for lane in range(WIDTH):
                child[chain][lane] = twig()
            break
        lanes = [{"t": twig, "f": fan, "c": node}[p]() for p in pattern]
        child[chain] = lanes
        chain = lanes[pattern.index("c")]
    return np.array(child), np.array(count), leaves


def test_counting_stack_holds_the_deepest_rounds():
    """COUNT_STACK_SIZE: on a tree as deep as the layout allows, built so
    that every round leaves 3 * ROUND pending nodes (_rounds_that_pile_up:
    340 at once for two nodes a round, where the single-ray bound
    STACK_SIZE is 184), a ray through every box and the one triangle all
    the leaves hold counts each leaf once (with a stack of STACK_SIZE the
    kernel crashed)."""
    from raytrace.accel.bvh.layout import CountingBVH, lane_entries
    from raytrace.accel.bvh.traverse import COUNT_STACK_SIZE, ROUND, STACK_SIZE
    levels = MAX_DEPTH - 3           # its twigs lie MAX_DEPTH - 1 levels down
    child, count, n = _rounds_that_pile_up(levels, PILE_UP[ROUND])
    tri = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    geo, _ = make_scene(np.tile(tri, (n, 1, 1)))
    used = child >= 0
    node_box = np.full((len(child), 6, WIDTH), np.inf, BOX)
    node_box[:, :3, :] = np.where(used[:, None, :], -2.0, np.inf)
    node_box[:, 3:, :] = np.where(used[:, None, :], 2.0, np.inf)
    prim_ids = np.arange(n)
    leaf_tris = np.full((9, n + 3), np.nan)
    leaf_tris[:, :n] = tri.reshape(9, 1)
    acc = CountingBVH(node_box, child, count, prim_ids, 2.0, lane_entries(child, count), leaf_tris,
                      ((child << 32) | count).ravel())
    assert 3 * ROUND * (levels - 1) > STACK_SIZE and 3 * ROUND * levels < COUNT_STACK_SIZE
    o = np.array([[0.1, 0.0, 1.0], [1.5, 1.5, 1.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    (c, k) = counts(geo, acc, o, d, np.full(2, np.inf))
    assert list(c) == [n, 0]
    assert k[NODES_VISITED] == 2 * len(child) + 2 * n


def test_coherent_rays_count_as_packets_through_edges_and_vertices():
    """Parallel rays on a lattice go as packets (accel/bvh/packet.py,
    count_packet) and meet a subdivided closed box exactly on its edges
    and vertices, where the crossing rule gives each crossing to one
    triangle: every ray through the box crosses it twice, and each ray's
    count and counters are the ones it has alone (a count never narrows a
    ray, so a packet visits what its rays visit one by one)."""
    import trimesh
    box = trimesh.creation.box().subdivide().subdivide().subdivide()   # edges every 1/8
    geo, ranges = make_scene(box.vertices[box.faces], [((0.0, 0.0, 3.0), 0.25)],
                             planes=[((0, 0, -2.0), (0, 0, 1))])
    bvh, _ = build_accel("bvh", geo, ranges)
    counting = get_structure("bvh").counting_layout(bvh, geo)
    brute, _ = build_accel("none", geo, ranges)
    xs = np.arange(-48, 48) / 64                       # 96 rays a row: 6 packets
    x, y = np.meshgrid(xs, xs)
    o = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 5.0)])
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    o[100, 0] = np.nan                                 # one packet goes ray by ray
    t_max = np.full(len(o), np.inf)
    (c, k), (c0, _) = counts(geo, counting, o, d, t_max), counts(geo, brute, o, d, t_max)
    assert np.array_equal(c, c0)
    # Off the box's side faces (a ray along a face is not a crossing) and
    # the sphere's tangents: the plane, the box twice, the sphere twice.
    ax, ay = np.abs(o[:, 0]), np.abs(o[:, 1])
    r = np.hypot(o[:, 0], o[:, 1])
    clear = (ax != 0.5) & (ay != 0.5) & (r != 0.25)
    expected = 1 + 2 * ((ax < 0.5) & (ay < 0.5)) + 2 * (r < 0.25)
    expected[100] = 0
    assert clear.sum() > 8000 and np.array_equal(c[clear], expected[clear])
    # Rays through the lattice's vertices and edges on the top face.
    assert (c[clear & (ax < 0.5) & (ay < 0.5) & (o[:, 0] * 8 % 1 == 0)] >= 3).all()
    one_at_a_time = sum(counts(geo, counting, o[i:i + 1], d[i:i + 1], t_max[i:i + 1])[1]
                        for i in range(len(o)))
    assert np.array_equal(k, one_at_a_time) and k[BAD_RAYS] == 1


def test_count_stream_takes_the_rays_as_they_come():
    """The BVH counts two rays in flight, each slot taking the next good
    ray when its own is done (accel/bvh/count_stream.py).  Bad rays
    first, in runs, last, and a batch of nothing else, get 0 and are
    counted; every good ray gets brute force's count (spheres' far roots
    and planes included), and the batch the counters its rays have one at
    a time."""
    rng = np.random.default_rng(11)
    geo, ranges = make_scene(random_soup(rng, 300, 0.2), [((0.3, 0.0, 0.1), 0.3)],
                             planes=[((0, -0.5, 0), (0, 1, 0))])
    bvh, _ = build_accel("bvh", geo, ranges)
    counting = get_structure("bvh").counting_layout(bvh, geo)
    brute, _ = build_accel("none", geo, ranges)
    n = 2500                                   # three chunks of rays
    o = rng.uniform(-1.2, 1.2, (n, 3))
    d = random_dirs(rng, n)
    t_max = np.where(rng.random(n) < 0.5, np.inf, rng.random(n) * 3)
    bad = [0, 1, 2, 700, 1023, 1024, 1025, 1800, 1801, n - 2, n - 1]
    o[bad[::3]] = np.nan
    d[bad[1::3]] = 0.0
    t_max[bad[2::3]] = 0.0                     # t_min 0 is not below it
    (c, k), (c0, k0) = counts(geo, counting, o, d, t_max), counts(geo, brute, o, d, t_max)
    assert k[BAD_RAYS] == k0[BAD_RAYS] == len(bad)
    assert np.array_equal(c, c0) and not c[bad].any() and c.sum() > n
    assert k[PRIM_HITS] == k0[PRIM_HITS]
    one_at_a_time = sum(counts(geo, counting, o[i:i + 1], d[i:i + 1], t_max[i:i + 1])[1]
                        for i in range(0, n, 7))
    k7 = counts(geo, counting, o[::7], d[::7], t_max[::7])[1]
    assert np.array_equal(k7, one_at_a_time)
    c, k = counts(geo, counting, o[bad], d[bad], t_max[bad])
    assert not c.any() and k[BAD_RAYS] == len(bad) and k[NODES_VISITED] == 0


def test_build_kernel_depth_reported():
    lo, hi = outward(*boxes_of(random_soup(np.random.default_rng(2), 1000, 0.01)))
    n = len(lo)
    nodes = (np.empty((2 * n, 3), BOX), np.empty((2 * n, 3), BOX), np.empty(2 * n, LINK),
             np.empty(2 * n, LINK))
    rows, depth, tasks = build_bvh_kernel(box_rows(lo, hi), np.arange(n), 0, n, 0, 4, 1.0, nodes,
                                          0, 0, np.empty((0, 4), np.int64))
    assert 0 < depth <= MAX_DEPTH and 0 < rows < 2 * n and tasks == 0


def _subtree_ranges(node_start, node_count):
    """[start, end) of prim_ids under each node of a depth-first binary tree."""
    first = np.zeros(len(node_start), np.int64)
    end = np.zeros(len(node_start), np.int64)
    for i in range(len(node_start) - 1, -1, -1):    # children come after parents
        if node_count[i] > 0:
            first[i], end[i] = node_start[i], node_start[i] + node_count[i]
        else:
            first[i], end[i] = first[i + 1], end[node_start[i]]
    return first, end


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("tree", ["tracing", "counting"])
def test_every_node_is_the_binned_sah_choice_over_its_own_primitives(seed, tree):
    """A reference for the builder, node by node, in NumPy: each box is its
    primitives' union, padded and rounded outwards; each split is the
    cheapest of the 3 x (N_BINS - 1) planes of bins over the node's own
    centroid box, its left child the primitives binned below the plane; a
    leaf is where no split pays, at the node visit's cost (the tracing
    tree's, or the counting tree's, accel/bvh.for_counting).  Mutations
    that took a child's boxes from the wrong side of its parent's split
    failed it."""
    from raytrace.accel.bvh.layout import (
        BOX_PAD,
        COUNT_LEAF,
        COUNT_TRAVERSAL_COST,
        MAX_LEAF,
        N_BINS,
        TRAVERSAL_COST,
    )
    max_leaf, cost = {"tracing": (MAX_LEAF, TRAVERSAL_COST),
                      "counting": (COUNT_LEAF, COUNT_TRAVERSAL_COST)}[tree]
    lo, hi = outward(*boxes_of(random_soup(np.random.default_rng(seed), 400, 0.05)))
    node_lo, node_hi, node_start, node_count, prim_ids = build_bvh(lo, hi, max_leaf, cost)
    first, end = _subtree_ranges(node_start, node_count)
    lo64, hi64 = lo.astype(np.float64), hi.astype(np.float64)

    def half_area(a, b):
        d = b - a
        return d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0]

    splits = 0
    for i in range(len(node_start)):
        ids = prim_ids[first[i]:end[i]]
        blo, bhi = lo64[ids].min(axis=0), hi64[ids].max(axis=0)
        pad = BOX_PAD * np.abs(np.concatenate([blo, bhi])).max()
        want_lo, want_hi = outward(blo - pad, bhi + pad)
        assert np.array_equal(node_lo[i], want_lo[0]) and np.array_equal(node_hi[i], want_hi[0])
        c = 0.5 * (lo64[ids] + hi64[ids])
        cmin, cext = c.min(axis=0), c.max(axis=0) - c.min(axis=0)
        costs = np.full((3, N_BINS), np.inf)
        for a in range(3):
            if cext[a] <= 0:
                continue
            b = np.minimum(((c[:, a] - cmin[a]) * (N_BINS / cext[a])).astype(np.int64), N_BINS - 1)
            for plane in range(1, N_BINS):
                left = b < plane
                m = int(left.sum())
                if 0 < m < len(ids):
                    costs[a, plane] = (m * half_area(lo64[ids][left].min(0), hi64[ids][left].max(0))
                                       + (len(ids) - m) * half_area(lo64[ids][~left].min(0),
                                                                    hi64[ids][~left].max(0)))
        best = int(np.argmin(costs))     # the first of equal costs, as the builder's sweep
        area = half_area(blo, bhi)
        splits_here = costs.flat[best] < np.inf and (
            len(ids) > max_leaf or cost * area + costs.flat[best] < len(ids) * area)
        assert (node_count[i] == 0) == splits_here, i
        if splits_here:
            a, plane = divmod(best, N_BINS)
            b = np.minimum(((c[:, a] - cmin[a]) * (N_BINS / cext[a])).astype(np.int64), N_BINS - 1)
            left = prim_ids[first[i + 1]:end[i + 1]]
            assert set(left.tolist()) == set(ids[b < plane].tolist()), i
            splits += 1
    assert splits >= len(lo) // max_leaf     # many decisions were checked


def test_rounding_to_float32_steps_by_bits_as_nextafter_would():
    """The builders' outward rounding steps a float32 by its bits: checked
    against NumPy's nextafter on zeros of both signs, subnormals, the ends
    of float32's range, infinities, and 20,000 values of every magnitude
    (in both directions, the bits compared, so -0.0 counts)."""
    from numba import njit

    from raytrace.accel.bvh.boxes import round_down as _round_down
    from raytrace.accel.bvh.boxes import round_up as _round_up
    down, up = njit(lambda x: _round_down(x)), njit(lambda x: _round_up(x))
    f32 = np.float32
    edges = [0.0, -0.0, 1e-50, -1e-50, 2.0**-149, -2.0**-149, 1.5 * 2.0**-149, 1e-40, -1e-40,
             2.0**-126, -2.0**-126, 1.0, -1.0, 1.0 + 2.0**-40, -1.0 - 2.0**-40, 1.0 - 2.0**-40,
             float(np.finfo(f32).max), -float(np.finfo(f32).max), 3.5e38, -3.5e38, 1e300, -1e300,
             np.inf, -np.inf]
    rng = np.random.default_rng(5)
    xs = np.concatenate([edges, rng.normal(size=20_000) * 10.0 ** rng.integers(-46, 39, 20_000)])
    with np.errstate(over="ignore"):
        near = xs.astype(f32)
    want_down = np.where(near > xs, np.nextafter(near, f32(-np.inf)), near)
    want_up = np.where(near < xs, np.nextafter(near, f32(np.inf)), near)
    got_down = np.array([down(x) for x in xs], f32)
    got_up = np.array([up(x) for x in xs], f32)
    assert got_down.tobytes() == want_down.tobytes()
    assert got_up.tobytes() == want_up.tobytes()


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_box_bounds_are_outward_prim_bounds_bit_for_bit(threads):
    """The big-mesh path's fused bounds (box_bounds) against the small
    one's two steps: signed zeros, spheres, and values beyond float32."""
    from raytrace.accel.bvh.boxes import box_bounds
    rng = np.random.default_rng(4)
    tris = random_soup(rng, 500, 0.3)
    tris[:20] = np.round(tris[:20])          # exact zeros, and -0.0 below
    tris[20:40] *= -0.0
    tris[40:45] *= 1e50                      # overflow float32: +-inf or its largest
    spheres = [((0.0, -0.0, 1e-30), 0.5), ((1e45, 0, 0), 1e44), ((0.1, 0.2, 0.3), 1e-3)]
    geo, _ = make_scene(tris, spheres=spheres)
    want = box_rows(*outward(*prim_bounds(geo)))
    got = box_bounds(geo, threads)
    assert want.dtype == got.dtype == BOX and want.tobytes() == got.tobytes()


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("split", [1, 2, 7, 64, 5000])
def test_parallel_build_gives_the_serial_tree(threads, split):
    """build_bvh_parallel builds subtrees apart, each into its own rows, and the
    collapse follows the top's links: the 4-wide tree must be the serial
    builder's, array for array, whatever the number of subtrees (split) and
    threads, on a soup, on coincident centroids and on a depth-capped chain."""
    s = 3.0 ** np.arange(-75, 75)
    chain_lo = np.stack([s, np.zeros_like(s), np.zeros_like(s)], axis=1)
    cases = [boxes_of(random_soup(np.random.default_rng(5), 3000, 0.02)),
             (np.tile([[-1.0, -1, -1]], (300, 1)), np.tile([[1.0, 1, 1]], (300, 1))),
             (chain_lo, chain_lo + 0.1 * s[:, None])]
    for lo, hi in cases:
        lo, hi = outward(lo, hi)
        binary = build_bvh(lo, hi)
        serial = collapse_bvh4(*binary[:4]) + (binary[4],)
        *binary, links = build_bvh_parallel(box_rows(lo, hi), 4, threads=threads, split=split)
        parallel = collapse_bvh4(*binary[:4], links) + (binary[4],)
        for a, b in zip(serial, parallel):
            assert np.array_equal(a, b)


def test_uneven_shares_split_a_subtree_and_keep_the_serial_tree():
    """Where the threads' shares of subtrees are uneven (3 threads, a few
    subtrees), build_bvh_parallel splits the largest subtree's root first,
    its row after the top's: the top gains rows, and the 4-wide tree is
    still the serial builder's, array for array."""
    lo, hi = outward(*boxes_of(random_soup(np.random.default_rng(5), 3000, 0.02)))
    binary = build_bvh(lo, hi)
    serial = collapse_bvh4(*binary[:4]) + (binary[4],)
    top_rows = {}
    for refine in (0, 4):
        *binary, links = build_bvh_parallel(box_rows(lo, hi), 4, threads=3, split=4,
                                            refine=refine)
        top_rows[refine] = len(links[2])
        parallel = collapse_bvh4(*binary[:4], links) + (binary[4],)
        for a, b in zip(serial, parallel):
            assert np.array_equal(a, b)
    assert top_rows[4] == top_rows[0] + 3 * 4   # four splits, three rows each


# ---------------------------------------------------------------- traversal

# Every structure and builder whose traversal prunes (brute force is the
# reference; per-object boxes of one soup are brute force with a box test).
PRUNING = [("bvh", {}), ("bvh", {"bvh_build": "median"}), ("bvh", {"bvh_build": "lbvh"}),
           ("bvh", {"leaf_size": 1}), ("bvh", {"leaf_size": 9}), ("grid", {}),
           ("grid", {"grid_density": 0.3}), ("kdtree", {})]


@pytest.mark.parametrize("name, build_opts", PRUNING)
@given(seed=st.integers(0, 2**32 - 1), n_tris=st.integers(0, 200),
       n_spheres=st.integers(0, 3), size=st.sampled_from([1e-3, 0.05, 0.3]),
       inside=st.booleans())
@PROPERTY
def test_matches_brute_force(name, build_opts, seed, n_tris, n_spheres, size, inside):
    rng = np.random.default_rng(seed)
    tris = random_soup(rng, n_tris, size)
    spheres = [(rng.random(3) * 2 - 1, 0.05 + 0.3 * rng.random()) for _ in range(n_spheres)]
    geo, ranges = make_scene(tris, spheres)
    n_rays = 300
    # Origins inside the soup's box or outside it, aimed roughly inwards.
    o = rng.random((n_rays, 3)) * 2 - 1 if inside else rng.standard_normal((n_rays, 3)) * 3
    d = random_dirs(rng, n_rays)
    if not inside:
        d[n_rays // 3:] -= o[n_rays // 3:] * 0.3
    t_max = rng.random(n_rays) * 4
    assert_same_as_brute(geo, ranges, o, d, t_max, name, **build_opts)


def test_axis_parallel_grid_of_rays():
    """Rays along +-x, +-y, +-z (other components exactly +-0.0) through a
    soup, including origins on box faces (0 * inf in the slab test)."""
    rng = np.random.default_rng(7)
    tris = random_soup(rng, 300, 0.1)
    geo, ranges = make_scene(tris, [((0.2, 0.1, 0.0), 0.25)])
    lo, hi = prim_bounds(geo)
    o, d = [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            for zero in (0.0, -0.0):
                k = 60
                org = rng.random((k, 3)) * 2.4 - 1.2
                # Half the origins sit exactly on a primitive box's face.
                j = rng.integers(0, len(lo), k // 2)
                other = (axis + 1) % 3
                org[: k // 2, other] = lo[j, other]
                org[:, axis] = -2.0 * sign
                dirs = np.full((k, 3), zero)
                dirs[:, axis] = sign
                o.append(org)
                d.append(dirs)
    o, d = np.concatenate(o), np.concatenate(d)
    assert_same_as_brute(geo, ranges, o, d, rng.random(len(o)) * 4)


def closed_mesh(nu, nv):
    """A bumpy UV sphere: a closed surface where neighbours share edges."""
    th = np.linspace(0, np.pi, nu + 1)
    ph = np.linspace(0, 2 * np.pi, nv + 1)[:-1]
    T, P = np.meshgrid(th, ph, indexing="ij")
    r = 1.0 + 0.1 * np.sin(5 * T) * np.cos(7 * P)
    v = np.stack([r * np.sin(T) * np.cos(P), r * np.cos(T), r * np.sin(T) * np.sin(P)], -1)
    v = v.reshape(-1, 3)
    idx = np.arange((nu + 1) * nv).reshape(nu + 1, nv)
    a, b = idx[:-1], idx[1:]
    c, e = np.roll(idx[1:], -1, axis=1), np.roll(idx[:-1], -1, axis=1)
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, e], -1).reshape(-1, 3)])
    return v, f


def test_closed_mesh_vertices_and_edges():
    """Rays aimed exactly at shared vertices and edge midpoints of a closed
    mesh, from outside and from the centre: hits on shared features tie
    between triangles and must resolve the same way (smaller id).  Rays from
    the centre to the poles run along (-0.0, 1, 0) etc. inside the x = 0 and
    z = 0 face planes of the pole triangles' boxes."""
    v, f = closed_mesh(16, 32)
    geo, ranges, _ = flatten(Scene("m", Camera((0, 0, 5), (0, 0, 0)), [Mesh(v, f)]))
    targets = np.concatenate([v, 0.5 * (v[f[:, 0]] + v[f[:, 1]]), 0.5 * (v[f[:, 1]] + v[f[:, 2]])])
    rng = np.random.default_rng(3)
    outside = rng.standard_normal((len(targets), 3)) * 3
    o = np.concatenate([outside, np.zeros_like(targets)])
    d = np.concatenate([targets - outside, targets])
    assert_same_as_brute(geo, ranges, o, d, rng.random(len(o)) * 5)


def test_empty_tree_and_planes():
    """No bounded primitive: the BVH is empty, traversal does nothing, and
    planes are still found (they live outside every structure)."""
    geo, ranges = make_scene(None, planes=[((0, -1, 0), (0, 1, 0))])
    acc, _ = build_accel("bvh", geo, ranges)
    assert len(acc.node_box) == 0 and len(acc.prim_ids) == 0
    rng = np.random.default_rng(4)
    o = rng.standard_normal((200, 3))
    d = random_dirs(rng, 200)
    assert_same_as_brute(geo, ranges, o, d, rng.random(200) * 4)
    (t, p, u, v), cnt = closest(geo, acc, o, d)
    assert cnt[BOX_TESTS] == 0 and cnt[NODES_VISITED] == 0
    assert set(np.unique(p)) <= {-1, 0}


def test_single_primitive():
    geo, ranges = make_scene([[[-1, -1, 0], [1, -1, 0], [0, 1, 0]]])
    acc, _ = build_accel("bvh", geo, ranges)
    o = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [5.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, -0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    (t, p, _, _), _ = closest(geo, acc, o, d)
    assert t.tolist() == [1.0, 1.0, np.inf, np.inf] and p.tolist() == [0, 0, -1, -1]
    assert_same_as_brute(geo, ranges, o, d, np.array([2.0, 0.5, 2.0, 2.0]))


def test_duplicate_triangles_tie_to_smaller_id():
    """Identical triangles hit at identical t: the smaller id wins, as in
    brute force, whatever order the leaves are visited in."""
    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], float)
    rng = np.random.default_rng(5)
    others = random_soup(rng, 40, 0.2)
    tris = np.concatenate([others[:20], [tri] * 10, others[20:]])
    geo, ranges = make_scene(tris)
    o = np.column_stack([rng.random((100, 2)) * 0.6 - 0.3, np.full(100, 3.0)])
    d = np.tile([0.0, 0.0, -1.0], (100, 1))
    assert_same_as_brute(geo, ranges, o, d, np.full(100, 10.0))


def test_fewer_primitive_tests_than_brute_force():
    v, f = closed_mesh(17, 32)  # 1088 faces, 64 degenerate ones at the poles
    geo, ranges, _ = flatten(Scene("m", Camera((0, 0, 5), (0, 0, 0)), [Mesh(v, f)]))
    assert len(geo.tri_v0) == 1024
    rng = np.random.default_rng(6)
    o = rng.standard_normal((2000, 3)) * 3
    d = rng.standard_normal((2000, 3)) * 0.3 - o
    brute, _ = build_accel("none", geo, ranges)
    bvh, _ = build_accel("bvh", geo, ranges)
    _, c0 = closest(geo, brute, o, d)
    _, c1 = closest(geo, bvh, o, d)
    assert c0[PRIM_TESTS] == 1024 * 2000
    assert c1[PRIM_TESTS] < c0[PRIM_TESTS] / 50
    assert c1[NODES_VISITED] > 0 and c1[BOX_TESTS] >= c1[NODES_VISITED]


@pytest.mark.parametrize("aimed", [True, False])
def test_occlusion_stops_early(aimed):
    """A shadow ray stops at its first occluder: it agrees with the closest
    hit on whether anything is hit, with never more primitive tests."""
    v, f = closed_mesh(16, 32)
    geo, ranges, _ = flatten(Scene("m", Camera((0, 0, 5), (0, 0, 0)), [Mesh(v, f)]))
    bvh, _ = build_accel("bvh", geo, ranges)
    rng = np.random.default_rng(8)
    o = rng.standard_normal((500, 3)) * 3
    d = -o if aimed else rng.standard_normal((500, 3))
    (t, p, _, _), cc = closest(geo, bvh, o, d)
    hit, co = occluded(geo, bvh, o, d, np.full(500, np.inf))
    assert np.array_equal(hit, p >= 0)
    assert co[PRIM_TESTS] <= cc[PRIM_TESTS]


@pytest.mark.parametrize("builder", ["sah", "median", "lbvh"])
@pytest.mark.parametrize("leaf_size", [1, 4, 9])
def test_every_builder_gives_the_brute_force_image(builder, leaf_size):
    from raytrace.accel.registry import get
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import spheres
    scene = spheres()
    kw = dict(width=48, height=36, shadows="hard")
    ref = render(scene, accel="none", **kw)
    r = render(scene, accel="bvh", bvh_build=builder, leaf_size=leaf_size, **kw)
    assert np.array_equal(r.linear, ref.linear)
    assert r.stats["structure"]["primitives_per_leaf_max"] <= max(leaf_size, 1) or builder == "sah"
    geo, ranges = make_scene(random_soup(np.random.default_rng(leaf_size), 300, 0.05))
    bvh, _ = get("bvh").build(geo, ranges, bvh_build=builder, leaf_size=leaf_size)
    lo, hi = prim_bounds(geo)
    wide_check(lo, hi, bvh.node_box, bvh.node_child, bvh.node_count, bvh.prim_ids)
    assert bvh.node_count.max() <= leaf_size
    # box_bound, read from the root's lanes, bounds every box of the tree
    # (the float32 box test's overflow argument rests on it).
    used = bvh.node_box[:, 0, :] < np.inf
    assert bvh.box_bound == np.abs(np.moveaxis(bvh.node_box, 1, 2)[used]).max() > 0


def test_a_scene_of_spheres_is_weighed_at_the_sphere_cost():
    """Spheres are tested one by one, triangles 4 at a time: the SAH weighs
    a node visit against the scene's mean test, so Whitted's two spheres get
    a leaf each (at the triangles' cost they shared one, and every ray into
    it tested both), and a triangle mesh keeps TRAVERSAL_COST."""
    from raytrace.accel.bvh.build import scene_traversal_cost
    from raytrace.accel.bvh.layout import SPHERE_TRAVERSAL_COST, TRAVERSAL_COST
    spheres = [((0.55, 1.0, 1.3), 0.8), ((-1.0, 1.2, -1.2), 1.2)]
    tri = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert scene_traversal_cost(make_scene(spheres=spheres)[0]) == SPHERE_TRAVERSAL_COST
    assert scene_traversal_cost(make_scene(tris=[tri] * 4)[0]) == TRAVERSAL_COST
    mixed = scene_traversal_cost(make_scene(tris=[tri] * 2, spheres=spheres)[0])
    assert SPHERE_TRAVERSAL_COST < mixed < TRAVERSAL_COST
    acc, _ = build_accel("bvh", *make_scene(spheres=spheres))
    assert sorted(acc.node_count[acc.node_count > 0].tolist()) == [1, 1]
