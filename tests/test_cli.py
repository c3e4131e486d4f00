"""The command line through click's CliRunner: exit codes, JSON, errors."""
import json

import pytest
from click.testing import CliRunner

from raytrace.cli.main import main

SMALL = ["--width", "48", "--height", "36"]


@pytest.fixture
def run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    def go(*args):
        return CliRunner().invoke(main, list(args))
    return go


def test_scenes_lists_builtins(run):
    r = run("scenes")
    assert r.exit_code == 0
    assert "teapot" in r.output and "spheres" in r.output


def test_render_writes_png_and_prints_table(run, tmp_path):
    r = run("teapot", "--no-bvol", "--shadows", "none", *SMALL)
    assert r.exit_code == 0, r.output
    assert (tmp_path / "teapot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for label in ("Render time", "Compile/load time", "Flatten time", "Load time",
                  "Primary rays", "Ray-primitive tests", "Ray-primitive hits", "Ray-box tests",
                  "Mrays/s"):
        assert label in r.output
    assert not list(tmp_path.glob("*.tmp"))


def test_workshop_command_line_works(run, tmp_path):
    r = run("teapot", "--shadows", "soft", "--no-bvol", "--light-samples", "4", *SMALL, "-o", "soft.png")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "soft.png").exists()


def test_json_parses_and_counts(run):
    r = run("spheres", "--bvol", "--shadows", "hard", "--json", *SMALL)
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    assert stats["accel"] == "bvol"
    assert stats["counters"]["primary_rays"] == 48 * 36
    assert stats["time"]["render_s"] > 0
    assert "compile_s" in stats["time"] and "build_s" in stats["time"]
    # Every phase of the command is reported, loading the scene included.
    assert stats["time"]["load_s"] > 0 and stats["time"]["setup_s"] > 0


def test_bvol_flags_map_to_accel(run):
    assert json.loads(run("spheres", "--no-bvol", "--json", *SMALL).output)["accel"] == "none"
    r = run("spheres", "--no-bvol", "--accel", "bvol", *SMALL)
    assert r.exit_code == 2 and "contradicts" in r.output


@pytest.mark.parametrize("args, code, text", [
    (["nosuchscene"], 2, "unknown scene 'nosuchscene'"),
    (["teapot", "--width", "0"], 2, "--width"),
    (["teapot", "--height", "-5"], 2, "--height"),
    (["teapot", "--light-samples", "-4"], 2, "--light-samples"),
    (["teapot", "--shadows", "soft", "--light-samples", "10"], 2, "square number"),
    (["teapot", "--accel", "octree"], 2, "--accel"),
    (["teapot", "--frobnicate"], 2, "No such option"),
    (["teapot", "--width", "1048576", "--height", "1048576"], 1, "GiB"),
    (["teapot", "-o", "missing_dir/out.png"], 1, "does not exist"),
    (["spheres", "--detail", "8"], 2, "teapot scene only"),
])
def test_bad_input_is_one_line_no_traceback_no_file(run, tmp_path, args, code, text):
    r = run(*args)
    assert r.exit_code == code, r.output
    assert text in r.output
    assert "Traceback" not in r.output
    error_lines = [ln for ln in r.output.splitlines() if ln.startswith("Error")]
    assert len(error_lines) == 1
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*.tmp"))
    assert r.exception is None or isinstance(r.exception, SystemExit)


def test_existing_output_untouched_on_failure(run, tmp_path):
    out = tmp_path / "keep.png"
    out.write_bytes(b"old")
    r = run("teapot", "--width", "0", "-o", str(out))
    assert r.exit_code == 2
    assert out.read_bytes() == b"old"


def test_output_file_has_the_usual_permissions(run, tmp_path):
    import os
    r = run("spheres", "--shadows", "none", *SMALL, "-o", "perm.png")
    assert r.exit_code == 0, r.output
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "perm.png").stat().st_mode & 0o777 == 0o666 & ~mask


@pytest.mark.parametrize("command", [[], ["compare", "--accel", "bvh"]])
def test_threads_bound_a_big_teapots_tessellation_too(run, monkeypatch, command):
    """--threads 1 tessellates on one thread (KERNEL_MIN lowered so that
    --detail 2 takes the kernels), not on every core."""
    import numba

    import raytrace.scene.teapot as teapot_module
    used = []
    tessellate = teapot_module._tessellate_parallel

    def spy(b, ctrl, detail, threads):
        used.append(threads)
        return tessellate(b, ctrl, detail, threads)

    monkeypatch.setattr(teapot_module, "KERNEL_MIN", 256)
    monkeypatch.setattr(teapot_module, "_tessellate_parallel", spy)
    try:
        r = run(*command, "teapot", "--detail", "2", "--threads", "1", *SMALL)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert r.exit_code == 0, r.output
    assert used[-1] == 1     # the scene's (load_kernels' own warm-up runs on one anyway)


TEAPOT_FILE = """
[camera]
position = [0, 2, 8]
look_at = [0, 0.5, 0]

[[objects]]
type = "teapot"
detail = 2
"""


@pytest.mark.parametrize("scene", ["builtin", "file"])
def test_a_big_teapots_tessellation_kernels_count_as_compile_time(run, monkeypatch, tmp_path,
                                                                   scene):
    """Their load (here a stand-in taking 0.5 s) goes to compile_s, not
    load_s, for the built-in teapot and a scene file's; KERNEL_MIN lowered
    so that detail 2 takes the kernels."""
    import time

    import raytrace.scene.teapot as teapot_module
    teapot_module.load_kernels(125)    # compiled (or loaded) now: not in load_s below
    monkeypatch.setattr(teapot_module, "KERNEL_MIN", 256)
    monkeypatch.setattr(teapot_module, "load_kernels", lambda detail: time.sleep(0.5) or 0.5)
    if scene == "file":
        (tmp_path / "pot.toml").write_text(TEAPOT_FILE)
        args = [str(tmp_path / "pot.toml")]
    else:
        args = ["teapot", "--detail", "2"]
    r = run(*args, "--json", *SMALL)
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    assert stats["time"]["compile_s"] >= 0.5 > stats["time"]["load_s"]


def test_kernels_compiled_while_a_mesh_file_loads_count_as_compile_time(run, monkeypatch, tmp_path):
    """A mesh file's reader and normals compile on first use, inside
    load_scene (here a stand-in compiling a fresh function as the file
    loads): that time goes to compile_s, not load_s."""
    import time

    import trimesh
    from numba import njit

    import raytrace.scene.load as load
    trimesh.creation.icosphere(1).export(tmp_path / "ball.ply")
    real, spent = load.load_scene, []

    def loading(*args, **kwargs):
        @njit(cache=False)
        def fresh(x):
            return sum([x * k for k in range(x)])
        t0 = time.perf_counter()
        fresh(3)
        spent.append(time.perf_counter() - t0)
        return real(*args, **kwargs)
    monkeypatch.setattr(load, "load_scene", loading)
    r = run(str(tmp_path / "ball.ply"), "--json", *SMALL)
    assert r.exit_code == 0, r.output
    times = json.loads(r.output)["time"]
    assert spent[0] > 0.05
    assert times["compile_s"] >= 0.95 * spent[0] and times["load_s"] < 0.5 * spent[0]


def test_rays_cut_by_max_depth_are_counted_and_named(run):
    """Glass rays the depth limit stops leave dark pixels: the table counts
    them and a line names the option to raise; a deep enough limit is quiet."""
    r = run("whitted", *SMALL, "--max-depth", "1")
    assert r.exit_code == 0, r.output
    assert "Rays cut by --max-depth" in r.output
    assert "mirror and glass rays were cut by --max-depth 1: raise it" in r.output
    r = run("teapot", *SMALL, "--json")
    assert json.loads(r.output)["counters"]["depth_limited_rays"] == 0
