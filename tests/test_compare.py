"""`raytrace compare` and --show-structure: the table, the identity check,
the figure's panels, and the structures' outlines."""
import json

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from raytrace.accel.registry import STRUCTURES, get
from raytrace.cli import compare as cmp
from raytrace.cli.main import main
from raytrace.errors import OptionError
from raytrace.renderer.driver import RenderOptions, camera_buffer, render
from raytrace.renderer.heatmap import colormap, log_scale
from raytrace.renderer.overlay import project
from tests.structures import STRUCTURES as ALL

SMALL = ["--width", "40", "--height", "30"]


@pytest.fixture
def run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return lambda *args: CliRunner().invoke(main, list(args))


@pytest.fixture(scope="module")
def comparison(spheres_scene):
    entries = cmp.parse_entries("none,bvh,bvh:lbvh,grid")
    return cmp.compare(spheres_scene, entries, RenderOptions(width=40, height=30), repeat=2)


def test_table_has_a_row_per_structure_and_says_the_images_agree(run, tmp_path):
    r = run("compare", "spheres", *SMALL, "--repeat", "1", "-o", "c.png")
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("Structure"))
    rows = [line.split()[0] for line in lines[header + 2:header + 2 + len(ALL)]]
    assert rows == ALL
    assert f"Images: identical from all {len(ALL)} structures" in r.output
    with Image.open(tmp_path / "c.png") as im:
        assert im.format == "PNG" and im.size[0] >= 3 * 320


def test_json_rows_speedup_and_equal_work(comparison):
    d = json.loads(json.dumps(cmp.to_dict(comparison)))
    assert [r["structure"] for r in d["table"]] == ["none", "bvh", "bvh:lbvh", "grid"]
    assert d["baseline"] == "none" and d["identical"] is True
    none, bvh = d["table"][0], d["table"][1]
    assert none["speedup"] == 1.0
    assert bvh["speedup"] == pytest.approx(none["render_s"] / bvh["render_s"])
    # Same rays from every structure; brute force tests every primitive.
    assert len({r["rays"] for r in d["table"]}) == 1
    assert bvh["prim_tests_per_ray"] < none["prim_tests_per_ray"]
    assert d["structures"]["bvh:lbvh"]["bvh_build"] == "lbvh"
    assert d["structures"]["bvh"]["bvh_build"] == "sah"


def test_render_time_is_the_best_of_the_repeats(comparison):
    for e in comparison.entries:
        assert e.render_s == e.stats["time"]["render_s"] > 0


def test_figure_panels_hold_the_image_and_heatmaps_on_one_scale(comparison):
    from raytrace.cli.figure import figure
    fig, panels = figure(comparison, "40x30")
    assert set(panels) == {"image", "none", "bvh", "bvh:lbvh", "grid"}
    costs = [e.cost for e in comparison.entries]
    lo, hi = min(c.min() for c in costs), max(c.max() for c in costs)

    def panel(name):
        x, y, w, h = panels[name]
        zoom = w // 40
        return fig[y:y + h:zoom, x:x + w:zoom]
    assert np.array_equal(panel("image"), comparison.image)
    for e in comparison.entries:
        assert np.array_equal(panel(e.label), colormap(log_scale(e.cost, lo, hi)))


def test_a_different_image_is_caught_and_named(spheres_scene, monkeypatch):
    def wrong_grid(scene, opts):
        result = render(scene, opts)
        if opts.accel == "grid":
            result.linear[0, 0, 0] += 1.0
        return result
    monkeypatch.setattr("raytrace.renderer.driver.render", wrong_grid)
    got = cmp.compare(spheres_scene, cmp.parse_entries("bvh,grid"), RenderOptions(width=8, height=6))
    assert not got.identical and got.differences == [("grid", 1)]
    assert cmp.identity_line(got) == "Images DIFFER: grid differs from bvh in 1 pixels"


@pytest.mark.parametrize("text, message", [
    ("bvh:fast", "unknown BVH builder 'fast'"),
    ("grid:sah", "only the BVH has builders"),
    ("bvh,bvh", "'bvh' is listed twice"),
    ("octree", "unknown acceleration structure 'octree'"),
])
def test_bad_structure_lists(text, message, run):
    with pytest.raises(OptionError, match=message):
        cmp.parse_entries(text)
    r = run("compare", "spheres", "--accel", text)
    assert r.exit_code == 2 and message in r.output


def test_show_structure_draws_only_lines_over_the_image(run, tmp_path):
    assert run("teapot", "--accel", "kdtree", *SMALL, "-o", "a.png").exit_code == 0
    r = run("teapot", "--accel", "kdtree", *SMALL, "--show-structure", "2", "--json", "-o", "b.png")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["structure_shown"]["depth"] == 2
    a, b = (np.asarray(Image.open(tmp_path / n)) for n in ("a.png", "b.png"))
    changed = (a != b).any(axis=2)
    assert 0 < changed.sum() < 0.5 * changed.size
    r = run("teapot", "--accel", "none", "--show-structure", "1", "-o", "c.png")
    assert r.exit_code == 2 and "no structure to show" in r.output
    assert not (tmp_path / "c.png").exists()


def test_projection_puts_the_look_at_point_in_the_centre(teapot_scene):
    cam = camera_buffer(teapot_scene.camera, 64, 48)
    (x, y), z = project(cam, np.array(teapot_scene.camera.look_at, float), 64, 48)
    assert (x, y) == pytest.approx((32.0, 24.0)) and z > 0


def _volume(lo, hi):
    return np.prod(hi - lo, axis=1)


@pytest.mark.parametrize("name", [n for n in STRUCTURES if n != "none"])
def test_outlines_nest_and_cover(name, teapot_scene):
    from raytrace.scene.flatten import flatten
    geo, ranges, _ = flatten(teapot_scene)
    s = get(name)
    layout, _ = s.build(geo, ranges)
    lo, hi, level = s.outline(layout, 3)
    assert len(lo) == len(hi) == len(level) > 0 and level.min() == 0 and level.max() <= 3
    # Every box lies inside the level-0 boxes' union box.
    top = level == 0
    assert (lo >= lo[top].min(axis=0) - 1e-12).all() and (hi <= hi[top].max(axis=0) + 1e-12).all()
    if name == "kdtree":
        # Each level's cells (with the leaves above it) tile the bounds.
        total = _volume(lo[top], hi[top]).sum()
        for d in range(1, 4):
            def has_children(k):
                return ((level == level[k] + 1) & (lo >= lo[k]).all(1) & (hi <= hi[k]).all(1)).any()
            above = [k for k in range(len(level)) if level[k] < d and not has_children(k)]
            vol = _volume(lo[level == d], hi[level == d]).sum() + _volume(lo[above], hi[above]).sum()
            assert vol == pytest.approx(total, rel=1e-9)
    if name == "grid":
        st = s.statistics(layout, len(geo.tri_v0))
        assert (level == 1).sum() == st["cells"] - st["empty_cells"]
    if name == "bvh":
        # The lanes at level 1 are the root's children; a deeper box lies in a shallower one.
        for k in np.flatnonzero(level >= 2):
            inside = (level == level[k] - 1) & (lo <= lo[k]).all(1) & (hi >= hi[k]).all(1)
            assert inside.any()


def test_speedup_keeps_two_figures_below_ten():
    assert [cmp.speedup_text(x) for x in (0.04512, 0.5, 2.14, 38.4)] == ["0.045x", "0.5x", "2.1x",
                                                                          "38x"]


def test_the_teaching_scenes_are_what_the_script_writes(tmp_path):
    import sys
    from pathlib import Path
    bench = Path(__file__).resolve().parent.parent / "bench"
    sys.path.insert(0, str(bench))
    try:
        import make_scenes
    finally:
        sys.path.remove(str(bench))
    make_scenes.main(tmp_path)
    for name in ("stadium.obj", "stadium.toml", "sizes.toml"):
        assert (tmp_path / name).read_bytes() == (make_scenes.ASSETS / name).read_bytes(), name


def test_in_the_stadium_the_grid_tests_far_more_than_the_bvh():
    from raytrace.scene.assets import assets_dir
    from raytrace.scene.load import load_scene
    scene = load_scene(assets_dir() / "stadium.toml", width=32, height=24)
    got = cmp.compare(scene, cmp.parse_entries("bvh,grid"), RenderOptions(shadows="none"))
    bvh, grid = cmp.rows(got)
    assert got.identical
    # The teapot's triangles crowd a few of the grid's stadium-sized cells.
    assert grid["prim_tests_per_ray"] > 20 * bvh["prim_tests_per_ray"]
