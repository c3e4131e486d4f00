"""Structure statistics, exact on small hand-made scenes, and shown by the
CLI for every structure."""
import json

import numpy as np
import pytest
from click.testing import CliRunner

from raytrace.accel.bvh.layout import TRAVERSAL_COST
from raytrace.accel.registry import STRUCTURES, get
from raytrace.cli.main import main
from raytrace.kernels.buffers import prim_bounds
from raytrace.scene.flatten import flatten
from raytrace.scene.model import Camera, Mesh, Scene


def scene_of(*tri_sets):
    objs = [Mesh(np.array(v, float), np.array([[0, 1, 2]]), name=f"m{k}")
            for k, v in enumerate(tri_sets)]
    geo, ranges, _ = flatten(Scene("s", Camera((0, 0, 5), (0, 0, 0)), objs))
    return geo, ranges


TWO_APART = ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[10, 0, 0], [11, 0, 0], [10, 1, 0]])


def test_bvh_of_two_triangles_far_apart():
    geo, ranges = scene_of(*TWO_APART)
    s = get("bvh")
    # Leaves of one: at TRAVERSAL_COST 2 the SAH never splits two triangles.
    bvh, _ = s.build(geo, ranges, leaf_size=1)
    st = s.statistics(bvh, 2)
    assert (st["nodes"], st["leaves"], st["max_depth"], st["mean_leaf_depth"]) == (1, 2, 1, 1.0)
    assert st["primitives_per_leaf_mean"] == 1.0 and st["primitives_per_leaf_max"] == 1
    assert st["leaf_size_histogram"]["1"] == 2
    # One root visit (TRAVERSAL_COST tests' worth), then each leaf's test
    # weighted by its box's share of the root box's area (the boxes are flat
    # triangles' boxes, padded by 1e-9).
    lo, hi = prim_bounds(geo)
    e = hi - lo
    leaf = e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]
    r = hi.max(axis=0) - lo.min(axis=0)
    root = r[0] * r[1] + r[1] * r[2] + r[2] * r[0]
    assert st["sah_cost"] == pytest.approx(TRAVERSAL_COST + leaf.sum() / root, rel=1e-6)
    assert st["memory_bytes"] == sum(a.nbytes for a in bvh if isinstance(a, np.ndarray))
    assert st["bytes_per_primitive"] == st["memory_bytes"] / 2


def test_bvh_sah_cost_is_summed_over_every_block_of_nodes(monkeypatch):
    """The SAH sums run a block of nodes at a time: with blocks of 3 nodes
    the cost is the one-block sum's, and it is the formula's, summed here
    over every lane."""
    import raytrace.accel.bvh.stats as bvh_module
    rng = np.random.default_rng(7)
    tris = rng.normal(size=(300, 3, 3))
    geo, ranges, _ = flatten(Scene("s", None, [Mesh(tris.reshape(-1, 3),
                                                    np.arange(900).reshape(-1, 3))]))
    bvh, _ = get("bvh").build(geo, ranges)
    whole = bvh_module.statistics(bvh, 300)["sah_cost"]
    monkeypatch.setattr(bvh_module, "STATS_BLOCK", 3)
    assert len(bvh.node_child) > 9
    assert bvh_module.statistics(bvh, 300)["sah_cost"] == pytest.approx(whole, rel=1e-12)
    box = bvh.node_box.astype(np.float64)
    with np.errstate(invalid="ignore"):      # unused lanes: inf - inf, not summed
        e = np.maximum(box[:, 3:, :] - box[:, :3, :], 0.0)
    area = e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]
    used = bvh.node_box[:, 0, :] < np.inf
    inner, leaf = used & (bvh.node_count == 0), used & (bvh.node_count > 0)
    root = box[0, :3][:, used[0]].min(axis=1), box[0, 3:][:, used[0]].max(axis=1)
    r = root[1] - root[0]
    root_area = r[0] * r[1] + r[1] * r[2] + r[2] * r[0]
    want = (TRAVERSAL_COST * (1.0 + area[inner].sum() / root_area)
            + (area * bvh.node_count)[leaf].sum() / root_area)
    assert whole == pytest.approx(want, rel=1e-9)


def test_bvh_leaf_depths_and_sizes_are_the_trees_walked_lane_by_lane(monkeypatch):
    """Leaves counted level by level and from a histogram of lane counts
    (statistics) against a recursive walk of every lane, on a tree many
    levels deep with leaves of every size up to 4."""
    import raytrace.accel.bvh.stats as bvh_module
    rng = np.random.default_rng(11)
    tris = rng.normal(size=(2000, 3, 3)) * [[1.0, 1.0, 0.05]]
    geo, ranges, _ = flatten(Scene("s", None, [Mesh(tris.reshape(-1, 3),
                                                    np.arange(6000).reshape(-1, 3))]))
    bvh, _ = get("bvh").build(geo, ranges)
    found = []                                  # (depth, primitives) of each leaf lane

    def walk(node, depth):
        for lane in range(4):
            child, count = bvh.node_child[node, lane], bvh.node_count[node, lane]
            if count > 0:
                found.append((depth + 1, count))
            elif child >= 0:
                walk(child, depth + 1)
    walk(0, 0)
    depths, counts = np.array(found).T
    st = bvh_module.statistics(bvh, 2000)
    assert depths.max() >= 4 and set(counts.tolist()) == {1, 2, 3, 4}
    assert st["leaves"] == len(found) and counts.sum() == 2000
    assert st["max_depth"] == depths.max()
    assert st["mean_leaf_depth"] == pytest.approx(depths.mean(), rel=1e-12)
    assert st["primitives_per_leaf_mean"] == pytest.approx(counts.mean(), rel=1e-12)
    assert st["primitives_per_leaf_max"] == 4
    assert [st["leaf_size_histogram"][k] for k in "1234"] == [int((counts == k).sum())
                                                              for k in (1, 2, 3, 4)]
    monkeypatch.setattr(bvh_module, "STATS_BLOCK", 5)
    assert bvh_module.statistics(bvh, 2000)["leaves"] == len(found)


def test_leaves_histogram_bins():
    """leaves() bins sizes 0, 1, 2, 3, 4, 5-8, 9-16, 17+ as np.histogram does."""
    from raytrace.accel.statistics import LEAF_BIN_LABELS, LEAF_BINS, leaves
    rng = np.random.default_rng(3)
    counts = rng.integers(0, 40, size=500)
    depths = rng.integers(0, 20, size=500)
    st = leaves(counts, depths)
    want = np.histogram(counts, bins=list(LEAF_BINS) + [np.inf])[0]
    assert list(st["leaf_size_histogram"].values()) == want.tolist()
    assert list(st["leaf_size_histogram"]) == list(LEAF_BIN_LABELS)
    assert (st["leaves"], st["max_depth"], st["primitives_per_leaf_max"]) == (
        500, depths.max(), counts.max())
    assert st["mean_leaf_depth"] == pytest.approx(depths.mean(), rel=1e-12)
    assert leaves([], []) == {"leaves": 0}
    assert leaves([2, 3], [1, 1])["leaf_size_histogram"]["17+"] == 0


def test_grid_and_kdtree_counts():
    geo, ranges = scene_of(*TWO_APART)
    grid, _ = get("grid").build(geo, ranges)
    st = get("grid").statistics(grid, 2)
    assert st["cells"] == int(np.prod(grid.grid_res)) == np.prod(st["resolution"])
    assert st["empty_cells"] == int((np.diff(grid.cell_start) == 0).sum())
    assert st["references"] == len(grid.cell_items) and st["references_per_primitive"] == st["references"] / 2
    kd, _ = get("kdtree").build(geo, ranges)
    st = get("kdtree").statistics(kd, 2)
    # Two primitives are a leaf already (MAX_LEAF): one node, listing each once.
    got = (st["nodes"], st["leaves"], st["max_depth"], st["references"], st["duplication"])
    assert got == (1, 1, 0, 2, 1.0)


@pytest.mark.parametrize("accel", list(STRUCTURES))
def test_cli_shows_structure_statistics(accel, tmp_path):
    r = CliRunner().invoke(main, ["teapot", "--accel", accel, "--width", "16", "--height", "12",
                                  "--json", "-o", str(tmp_path / "t.png")])
    assert r.exit_code == 0, r.output
    st = json.loads(r.output)["structure"]
    assert st["memory_bytes"] >= 0
    table = CliRunner().invoke(main, ["teapot", "--accel", accel, "--width", "16", "--height", "12",
                                      "-o", str(tmp_path / "t.png")]).output
    assert "Structure: memory (bytes)" in table


# Four triangles: two unit squares in the plane z = 0, ten units apart.
FOUR = ([[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]],
        [[10, 0, 0], [11, 0, 0], [11, 1, 0]], [[10, 0, 0], [11, 1, 0], [10, 1, 0]])


@pytest.mark.parametrize("leaf_size, leaves, per_leaf", [(4, 2, 2), (1, 4, 1)])
def test_bvh_of_four_triangles_is_the_known_tree(leaf_size, leaves, per_leaf):
    """By the SAH (half areas of flat boxes: a square 1, the root 11): a leaf
    of four costs 4, splitting the squares apart 1 + (2 + 2) / 11; a square's
    two triangles share its box, so splitting them costs 1 + 1 + 1 against 2
    for a leaf.  With leaves of one they must split, and the 4-wide
    collapse lifts all four leaves into the root."""
    geo, ranges = scene_of(*FOUR)
    s = get("bvh")
    bvh, _ = s.build(geo, ranges, leaf_size=leaf_size)
    st = s.statistics(bvh, 4)
    got = (st["nodes"], st["leaves"], st["max_depth"], st["mean_leaf_depth"],
           st["primitives_per_leaf_max"], st["leaf_size_histogram"][str(per_leaf)])
    assert got == (1, leaves, 1, 1.0, per_leaf, leaves)
    lanes = sorted(tuple(sorted(bvh.prim_ids[c:c + n].tolist()))
                   for c, n in zip(bvh.node_child[0], bvh.node_count[0]) if n > 0)
    assert lanes == ([(0, 1), (2, 3)] if leaf_size == 4 else [(0,), (1,), (2,), (3,)])


@pytest.mark.parametrize("name", ["bvh", "grid", "kdtree", "bvol", "none"])
def test_statistics_call_no_blas(monkeypatch, name):
    """A structure's statistics, made after each render, call no BLAS
    routine: OpenBLAS's threads spin for a while after a threaded call and
    took the cores of the render that followed in the same process (a warm
    118k-triangle render: 45-59 ms, not 30)."""
    rng = np.random.default_rng(2)
    tris = rng.normal(size=(3000, 3, 3))
    mesh = Mesh(tris.reshape(-1, 3), np.arange(9000).reshape(-1, 3))
    geo, ranges, _ = flatten(Scene("s", None, [mesh]))
    s = get(name)
    layout, _ = s.build(geo, ranges)

    def blas(*args, **kwargs):
        raise AssertionError("a BLAS routine was called")
    for routine in ("dot", "vdot", "inner", "matmul", "tensordot"):
        monkeypatch.setattr(np, routine, blas)
    assert s.statistics(layout, 3000)
