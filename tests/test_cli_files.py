"""The command line with files: mesh and scene files in, AOVs and heatmaps
out, bad files rejected in one line with nothing written."""
import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from raytrace.cli import main as cli
from raytrace.cli.main import main
from raytrace.renderer.heatmap import VIRIDIS, colormap, cost_heatmap, legend_height
from raytrace.scene.assets import assets_dir
from tests.test_mesh_io import bad_mesh_files
from tests.test_scenefile import BAD

SMALL = ["--width", "48", "--height", "36"]


@pytest.fixture
def run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    def go(*args):
        return CliRunner().invoke(main, [str(a) for a in args])
    return go


@pytest.fixture
def house(tmp_path):
    shutil.copy(assets_dir() / "house.obj", tmp_path / "house.obj")
    return tmp_path / "house.obj"


def one_error_line(r, tmp_path, code=1):
    assert r.exit_code == code, r.output
    assert "Traceback" not in r.output
    lines = r.output.strip().splitlines()
    errors = [ln for ln in lines if ln.startswith("Error: ")]
    assert len(errors) == 1, r.output
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.npz"))
    assert not list(tmp_path.glob(".*.tmp"))
    return errors[0]


def test_scenes_lists_builtins_and_example_files(run):
    r = run("scenes")
    assert r.exit_code == 0
    for word in ("teapot", "spheres", "  village ", "  whitted ", str(assets_dir())):
        assert word in r.output
    assert "village.toml" not in r.output     # listed by the short name that renders it


def test_example_scene_by_short_name(run, tmp_path):
    """`raytrace village` is `raytrace assets/village.toml`; a file of that
    name in the working directory would win, an unknown name lists them."""
    r = run("village", *SMALL, "--shadows", "soft", "--pattern", "random", "-q")
    assert r.exit_code == 0, r.output
    assert Image.open(tmp_path / "village.png").size == (48, 36)
    r = run("villag", *SMALL)
    assert r.exit_code == 2 and "village, whitted" in r.output


def test_mesh_file_renders_with_views(run, tmp_path, house):
    r = run("house.obj", *SMALL, "--shadows", "none", "--json")
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    assert stats["scene"] == "house" and stats["triangles"] == 14 and stats["planes"] == 1
    assert Image.open(tmp_path / "house.png").size == (48, 36)
    for view in (["--view", "top"], ["--view", "30,-10", "--up", "z"], ["--up", "-x"]):
        r = run("house.obj", *SMALL, "--shadows", "none", "-q", "-o", "v.png", *view)
        assert r.exit_code == 0, (view, r.output)


def test_scene_file_renders(run, tmp_path):
    r = run(assets_dir() / "village.toml", *SMALL, "--shadows", "soft", "--pattern", "random", "-q")
    assert r.exit_code == 0, r.output
    assert Image.open(tmp_path / "village.png").size == (48, 36)


@pytest.mark.parametrize("args, text", [
    (["teapot", "--view", "top"], "--view applies to mesh files only"),
    (["teapot", "--up", "z"], "--up applies to mesh files only"),
    (["house.obj", "--view", "sideways"], "neither a view"),
    (["house.obj", "--view", "10,100"], "elevation must be between -90 and 90"),
    (["house.obj", "--up", "w"], "--up"),
    (["teapot", "--aov", "depth,colour"], "unknown AOV 'colour'"),
    (["teapot", "--heatmap", "teapot.png"], "--heatmap must differ"),
    (["teapot.tom"], "unknown scene 'teapot.tom'"),
])
def test_usage_errors(run, tmp_path, house, args, text):
    line = one_error_line(run(*args, *SMALL), tmp_path, code=2)
    assert text in line


def test_a_directory_is_named_as_one(run, tmp_path):
    (tmp_path / "meshes").mkdir()
    line = one_error_line(run("meshes", *SMALL), tmp_path, code=2)
    assert line.startswith("Error: meshes: is a directory, not a scene or mesh file"), line


def test_bad_mesh_files(run, tmp_path):
    d = tmp_path
    for name, (data, _) in bad_mesh_files(tmp_path / "..").items():
        (d / name).write_bytes(data)
    for name in [*bad_mesh_files(tmp_path / "..").keys(), "missing.obj"]:
        line = one_error_line(run(name, *SMALL), tmp_path)
        assert line.startswith(f"Error: {name}: "), line


@pytest.mark.parametrize("text, message", BAD)
def test_bad_scene_files(run, tmp_path, text, message):
    (tmp_path / "broken.obj").write_bytes(b"\x00\x01garbage\xff" * 50)
    (tmp_path / "scene.toml").write_text(text)
    line = one_error_line(run("scene.toml", *SMALL), tmp_path)
    assert line.startswith("Error: scene.toml: ") and message in line, line


def test_aov_npz_beside_the_png(run, tmp_path):
    r = run("spheres", *SMALL, "--shadows", "none", "--aov", "depth,normal,primid", "-o", "out/s.png")
    assert r.exit_code == 1 and "does not exist" in r.output     # checked before rendering
    (tmp_path / "out").mkdir()
    r = run("spheres", *SMALL, "--shadows", "none", "--aov", "depth,normal,primid", "-o", "out/s.png")
    assert r.exit_code == 0, r.output
    assert "wrote out/s.aov.npz (depth, normal, primid)" in r.output
    with np.load(tmp_path / "out" / "s.aov.npz") as z:
        assert sorted(z.files) == ["depth", "normal", "primid"]
        depth, normal, prim = z["depth"], z["normal"], z["primid"]
    assert depth.shape == prim.shape == (36, 48) and normal.shape == (36, 48, 3)
    assert depth.dtype == np.float32 and prim.dtype == np.int64
    miss = prim == -1
    assert miss.any() and (~miss).any()              # sky and scene both in view
    assert np.all(np.isinf(depth[miss])) and np.all(np.isfinite(depth[~miss]))
    assert np.allclose(np.linalg.norm(normal[~miss], axis=-1), 1, atol=1e-5)
    assert not list((tmp_path / "out").glob(".*.tmp"))


def test_heatmap_png_and_its_range(run, tmp_path):
    r = run("teapot", *SMALL, "--shadows", "none", "--bvol", "--heatmap", "heat.png", "--json")
    assert r.exit_code == 0, r.output
    hm = json.loads(r.output)["heatmap"]
    assert hm["path"] == "heat.png" and 0 < hm["cost_min"] < hm["cost_max"]
    img = np.asarray(Image.open(tmp_path / "heat.png"))
    assert img.shape == (36 + legend_height(36), 48, 3)
    assert (img[:36] == colormap(0.0)).all(axis=-1).any()      # the cheapest pixels
    assert (img[:36] == colormap(1.0)).all(axis=-1).any()      # the dearest
    # Brute force tests every primitive for every camera ray: one cost.
    r = run("teapot", *SMALL, "--shadows", "none", "--no-bvol", "--heatmap", "heat.png")
    assert "wrote heat.png (box + primitive tests per pixel, log scale: 993 = dark purple to 993" in r.output


def test_colormap_and_legend():
    assert colormap(0.0).tolist() == VIRIDIS[0].tolist()
    assert colormap(1.0).tolist() == VIRIDIS[-1].tolist()
    assert colormap(-5.0).tolist() == VIRIDIS[0].tolist() and colormap(7).tolist() == VIRIDIS[-1].tolist()
    cost = np.array([[1, 10, 100, 1000]] * 20)
    img, lo, hi = cost_heatmap(cost)
    assert (lo, hi) == (1, 1000)
    # Log scale: log(1 + cost) from the minimum to the maximum.
    x = (np.log1p(cost[0]) - np.log1p(1)) / (np.log1p(1000) - np.log1p(1))
    assert img[0].tolist() == colormap(x).tolist()
    assert (img[20] == 0).all()                       # the rule above the legend
    flat, lo, hi = cost_heatmap(np.full((4, 4), 7))
    assert (lo, hi) == (7, 7) and (flat[:4] == colormap(0.0)).all()


def test_heatmap_legend_writes_its_numbers():
    """Under the ramp, the costs at its ends and at each power of ten are
    written where they fall (white text on black), so -q keeps the scale."""
    from raytrace.renderer.heatmap import label_height, log_scale
    cost = np.tile(np.geomspace(1, 1000, 240).round().astype(int), (120, 1))
    img, lo, hi = cost_heatmap(cost)
    labels = img[-label_height(120):]
    assert set(np.unique(labels)) > {0} and (labels[0] == 0).all()
    ink = (labels > 128).all(axis=-1).any(axis=0)           # columns with (anti-aliased) white text
    for c in (lo, 10, 100, hi):
        x = int(round(float(log_scale(c, lo, hi)) * 239))
        assert ink[max(0, x - 12):x + 12].any(), c
    assert not ink[90:125].any()                                 # between 10 (x 65) and 100 (x 151)


def test_no_progress_bar_without_a_terminal_or_with_quiet(run, monkeypatch):
    monkeypatch.setattr(cli._Progress, "DELAY_S", 0.0)
    r = run("spheres", *SMALL, "--shadows", "none")
    assert r.exit_code == 0 and "rendering" not in r.output      # CliRunner: not a tty
    monkeypatch.setattr(cli, "_is_tty", lambda stream: True)
    r = run("spheres", *SMALL, "--shadows", "none", "-o", "b.png")
    assert r.exit_code == 0 and "rendering" in r.output          # the control: it can show
    r = run("spheres", *SMALL, "--shadows", "none", "--quiet", "-o", "c.png")
    assert r.exit_code == 0 and r.output == ""


def test_listing_help_and_bad_files_import_neither_numba_nor_trimesh(tmp_path):
    import subprocess
    import sys
    bad_scene = tmp_path / "bad.toml"
    bad_scene.write_text("[camera\n")
    code = ("import sys; from raytrace.cli.main import main\n"
            f"for args in (['scenes'], ['render', '--help'], ['nosuch.obj'], [{str(bad_scene)!r}]):\n"
            "    try: main(args)\n"
            "    except SystemExit: pass\n"
            "bad = [m for m in ('numba', 'trimesh') if m in sys.modules]\n"
            "assert not bad, bad\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "nosuch.obj: no such file" in out.stderr and "bad.toml" in out.stderr
    assert "village" in out.stdout and "--heatmap" in out.stdout
