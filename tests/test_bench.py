"""The benchmark scripts' arithmetic: error measures, slopes, the run
policy and the regression check, on hand-computed cases (no rendering);
and the scaling table's shape, from a tiny run of that section."""
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))

import common  # noqa: E402
import regress  # noqa: E402


def test_rmse_and_psnr_hand_computed():
    a = np.zeros((2, 2, 3), np.float32)
    b = a.copy()
    b[0, 0, 0] = 0.6          # one of 12 values off by 0.6: mean square 0.03
    assert common.rmse(b, a) == pytest.approx(math.sqrt(0.03))
    assert common.psnr(0.1) == pytest.approx(20.0)
    assert common.psnr(0.0) == math.inf


def test_loglog_slope_recovers_power_law():
    n = np.array([1, 4, 16, 64, 256])
    assert common.loglog_slope(n, 3.0 * n ** -0.5) == pytest.approx(-0.5)
    assert common.loglog_slope(n, 0.2 * n ** -1.0) == pytest.approx(-1.0)
    assert math.isnan(common.loglog_slope([4], [1.0]))


def test_interleaved_gives_slow_cells_fewer_runs_in_rounds():
    cost = {"slow": 10.0, "fast": 1.0}
    order = []

    def run(c):
        order.append(c)
        return cost[c], c
    times, first = common.interleaved(["slow", "fast"], run, budget_s=4.0, max_runs=3)
    assert len(times["slow"]) == 1          # floor(4 / 10) -> at least 1
    assert len(times["fast"]) == 3          # floor(4 / 1) = 4 -> capped at 3
    assert order == ["slow", "fast", "fast", "fast"]
    assert first == {"slow": "slow", "fast": "fast"}


def test_markdown_table_aligns_columns():
    t = common.markdown_table(["a", "bb"], [["x", 1], ["yyy", 22]])
    assert t.splitlines() == ["| a   | bb |", "| --- | -: |", "| x   |  1 |", "| yyy | 22 |"]


BASE = {"counters": {"bvh": {"prim_tests_per_ray": 10.0, "nodes_per_ray": 20.0, "rays": 5},
                     "grid": {"prim_tests_per_ray": 4.0, "cells_per_ray": 6.0, "rays": 5}}}


def test_regress_counters_within_two_percent_pass():
    now = {"bvh": {"prim_tests_per_ray": 10.19, "nodes_per_ray": 19.7},
           "grid": {"prim_tests_per_ray": 4.0, "cells_per_ray": 6.1}}
    _, fails = regress.check_counters(BASE, now)
    assert fails == []


def test_regress_counters_fail_both_ways_and_when_missing():
    now = {"bvh": {"prim_tests_per_ray": 10.5, "nodes_per_ray": 19.0}}
    _, fails = regress.check_counters(BASE, now)
    text = "\n".join(fails)
    assert "bvh prim_tests_per_ray" in text and "+5.0%" in text and "worse" in text
    assert "bvh nodes_per_ray" in text and "-5.0%" in text and "--update-baseline" in text
    assert "grid prim_tests_per_ray: no value measured" in text
    assert len(fails) == 4


def test_regress_floors():
    ok = {a: f * 1.01 for a, f in regress.FLOORS.items()}
    assert regress.check_ratios(ok) == []
    low = dict(ok, grid=regress.FLOORS["grid"] * 0.5)
    assert regress.check_ratios(low) == [
        f"grid/none speedup {regress.FLOORS['grid'] * 0.5:.1f}x is below its floor "
        f"{regress.FLOORS['grid']:g}x"]


def test_baseline_file_matches_the_script():
    import json
    base = json.loads(regress.BASELINE.read_text())
    assert base["scene"] == regress.COUNTER_SCENE
    assert set(base["counters"]) == ({regress.row_name(a, regress.COUNTER_SCENE["detail"])
                                      for a in regress.COUNTERS}
                                     | {regress.row_name(a, regress.MID_DETAIL)
                                        for a in regress.MID_COUNTERS})


def test_scaling_table_reports_size_memory_and_whole_command():
    """bench.sh's scaling section on two tiny sizes, the second past the
    one-run threshold: each cell has its structure's bytes per triangle, and
    at the sizes asked (--quick: the biggest only) a fresh process's peak
    memory and wall time, and the table shows them ("-" elsewhere)."""
    import bench
    # Two structures: the table's rows and cells are the same code for each.
    cfg = dict(bench.QUICK, scaling_size=(32, 24), scaling_details=(2, 3), scaling_runs=2,
               scaling_big=2, scaling_whole=(3,), scaling_structures=("bvh", "grid"))
    res = bench.run_scaling(cfg)
    assert [(r["detail"], r["runs"]) for r in res["rows"]] == [(2, 2), (3, 1)]
    for row in res["rows"]:
        assert list(row["cells"]) == ["bvh", "grid"]
        for a in ("bvh", "grid"):
            c = row["cells"][a]
            assert len(c["times_s"]) == len(c["build_times_s"]) == row["runs"]
            assert c["structure_bytes"] > 0
            assert c["structure_bytes_per_triangle"] == pytest.approx(c["structure_bytes"] / row["triangles"])
            if row["detail"] == 2:
                assert c["whole_s"] is None and c["peak_mb"] is None
                continue
            # The fresh process built the same structure for the same mesh.
            assert c["process"]["triangles"] == row["triangles"]
            assert c["process"]["structure_bytes"] == c["structure_bytes"]
            assert c["whole_s"] > c["process"]["time"]["render_s"] + c["process"]["time"]["build_s"]
            if sys.platform.startswith("linux"):
                assert c["peak_mb"] > 0
    json.dumps(res, default=bench._json_default)
    md = bench.scaling_markdown(res)
    header = [h.strip() for h in md.splitlines()[2].strip("|").split("|")]
    for col in ("Triangles", "Build ms", "Render s", "Mrays/s", "Structure B/triangle", "Peak MB",
                "Whole s"):
        assert col in header
    assert len(md.splitlines()) == 4 + 2 * 2 + 2
    assert "details above 2 (3) one render each" in md
    assert "per row at detail 3 only" in md
    first = [c.strip() for c in md.splitlines()[4].strip("|").split("|")]
    assert first[0] == "2" and first[-2:] == ["-", "-"]


def test_payload_is_what_a_worker_unpickles():
    """bench/payload.py's size is the pickled Setup.payload() a Dask worker
    receives: it holds every triangle's corners and the BVH, and unpickles
    to the same arrays."""
    import pickle

    import payload
    from click.testing import CliRunner

    import raytrace
    from raytrace.renderer.driver import options_with, prepare
    out = CliRunner().invoke(payload.main, ["teapot", "--detail", "4"]).output
    setup = prepare(raytrace.load_scene("teapot", detail=4),
                    options_with(None, dict(accel="bvh", shadows="soft")), drop_meshes=True)
    data = pickle.dumps(setup.payload(), protocol=pickle.HIGHEST_PROTOCOL)
    n = setup.geo.tri_v0.shape[0]
    assert f"{n:,} triangles, payload {len(data) / 1e6:,.1f} MB" in out
    assert len(data) > n * 72 + setup.acc.node_box.nbytes      # corners and node boxes
    geo = pickle.loads(data)[0]
    assert np.array_equal(geo.tri_v0, setup.geo.tri_v0)


def test_mesh_layouts_read_back_as_the_teapot(tmp_path):
    """bench/make_layouts.py's files (the meshfiles section's input), read
    by read_mesh_parts, hold the teapot's triangles: the rich PLY's quads
    and triangles, the OBJ's a/b/c corners, the STL's welded soup."""
    import subprocess

    import make_layouts

    from raytrace.scene.formats.mesh import read_mesh_parts
    from raytrace.scene.teapot import tessellate
    subprocess.run([sys.executable, make_layouts.__file__, "3", str(tmp_path)], check=True,
                   capture_output=True)
    v, f, _ = tessellate(3)

    def triangles(vertices, faces):
        """The triangles' corners as float32, each from its least corner on
        (winding kept), sorted."""
        t = vertices[faces].astype(np.float32).tolist()
        return sorted(min(r[k:] + r[:k] for k in range(3)) for r in t)
    written = {"obj.obj": "%.8g", "obj-plain.obj": "%.8g", "stl-ascii.stl": "%e"}   # text layouts
    for name in make_layouts.NAMES:
        (part,) = read_mesh_parts(tmp_path / f"teapot-3-{name}")
        fmt = written.get(name)
        want = triangles(v if fmt is None else np.vectorize(lambda x, fmt=fmt: float(fmt % x))(v), f)
        assert triangles(part.vertices, part.faces) == want, name


def test_quick_leaves_the_cold_start_section_to_be_asked_for():
    import bench
    assert bench.chosen_sections(None, quick=False) == list(bench.SECTIONS)
    assert bench.chosen_sections(None, quick=True) == [s for s in bench.SECTIONS if s != "coldstart"]
    assert bench.chosen_sections("coldstart, workshop", quick=True) == ["coldstart", "workshop"]
