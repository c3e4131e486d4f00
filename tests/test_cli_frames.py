"""`raytrace SCENE --turntable N`, -o with frames, --resume, --tiles and
--workers through the command line: what is written, and one line for
each mistake."""
import json
import signal

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from raytrace.cli.main import main

SIZE = ["--width", "40", "--height", "30"]


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def pixels(path):
    return np.asarray(Image.open(path).convert("RGB"))


def test_png_sequence_first_frame_is_the_still_and_resume_fills_the_gaps(tmp_path):
    r = run("teapot", *SIZE, "-o", tmp_path / "still.png", "-q")
    assert r.exit_code == 0, r.output
    r = run("teapot", *SIZE, "--turntable", 3, "-o", tmp_path / "f_%02d.png", "--json")
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    assert stats["frames"] == 3 and stats["counters"]["primary_rays"] == 3 * 40 * 30
    names = sorted(p.name for p in tmp_path.glob("f_*.png"))
    assert names == ["f_00.png", "f_01.png", "f_02.png"]
    assert np.array_equal(pixels(tmp_path / "f_00.png"), pixels(tmp_path / "still.png"))
    kept = (tmp_path / "f_01.png").read_bytes()
    (tmp_path / "f_01.png").unlink()
    r = run("teapot", *SIZE, "--turntable", 3, "-o", tmp_path / "f_%02d.png", "--resume")
    assert r.exit_code == 0, r.output
    assert "wrote 1 frames to" in r.output and "(2 already there)" in r.output
    assert (tmp_path / "f_01.png").read_bytes() == kept


def test_turntable_gif_by_default_named_after_the_scene(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = run("teapot", *SIZE, "--turntable", 4, "--fps", 10, "-q")
    assert r.exit_code == 0, r.output
    gif = Image.open(tmp_path / "teapot.gif")
    assert gif.n_frames == 4 and gif.size == (40, 30)
    assert gif.info["duration"] == 100


def test_a_scene_files_animation_renders_its_keyframes(tmp_path):
    scene = tmp_path / "orbit.toml"
    scene.write_text('''
[camera]
position = [0, 2, 8]
look_at = [0, 0.5, 0]
[[lights]]
position = [4, 6, 4]
[[objects]]
type = "sphere"
center = [0, 0.5, 0]
radius = 1
[animation]
frames = 3
[[animation.keys]]
frame = 0
position = [0, 2, 8]
look_at = [0, 0.5, 0]
[[animation.keys]]
frame = 2
position = [8, 2, 0]
look_at = [0, 0.5, 0]
''')
    r = run(scene, *SIZE, "-o", tmp_path / "k_%d.png", "-q")
    assert r.exit_code == 0, r.output
    r = run(scene, *SIZE, "-o", tmp_path / "still.png", "-q")      # a still: the [camera]
    assert r.exit_code == 0, r.output
    assert np.array_equal(pixels(tmp_path / "k_0.png"), pixels(tmp_path / "still.png"))
    assert not np.array_equal(pixels(tmp_path / "k_1.png"), pixels(tmp_path / "k_2.png"))


@pytest.mark.parametrize("args, code, words", [
    (["--fps", "12"], 2, "--fps applies to frame sequences"),
    (["--resume"], 2, "--resume applies to frame sequences"),
    (["--turntable", "2", "--aov", "depth"], 2, "--aov applies to still images"),
    (["--tiles", "2", "--heatmap", "h.png"], 2, "--heatmap needs the whole image"),
    (["--workers", "2", "--scheduler", "tcp://x:1"], 2, "give one"),
    (["--turntable", "2", "-o", "spin.png"], 2, "for frames use .gif, .mp4"),
    (["--turntable", "2", "-o", "spin.gif", "--resume"], 2, "--resume needs a PNG sequence"),
    (["-o", "spin.gif"], 1, "has no [animation] table"),
])
def test_mistakes_are_one_line(tmp_path, monkeypatch, args, code, words):
    monkeypatch.chdir(tmp_path)
    r = run("teapot", *SIZE, *args)
    assert r.exit_code == code, r.output
    # (click's usage lines come first here; the command itself, raytrace.cli.main.entry,
    # prints only the last: tests/test_hardening.py)
    assert words in r.output.strip().splitlines()[-1] and "Traceback" not in r.output
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_during_a_gif_leaves_no_file(tmp_path, monkeypatch):
    from raytrace.frames import batch
    real = batch.render_tile
    calls = []

    def interrupted_after_one(*args):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)
    monkeypatch.setattr(batch, "render_tile", interrupted_after_one)
    r = run("teapot", *SIZE, "--turntable", 3, "-o", tmp_path / "spin.gif")
    assert r.exit_code == 130 and "interrupted: no animation written" in r.output
    assert list(tmp_path.iterdir()) == []


def test_a_signal_a_library_turned_into_its_own_error_still_ends_the_animation(
        tmp_path, monkeypatch):
    """A SIGTERM landing in a library's C code can come back as that
    library's exception (interrupt.py); the animation says it wrote nothing,
    as for a KeyboardInterrupt, not "no image written"."""
    from raytrace.frames import batch
    from raytrace.renderer import interrupt
    real = batch.render_tile
    calls = []

    def terminated_after_one(*args):
        calls.append(1)
        if len(calls) == 2:
            monkeypatch.setattr(interrupt, "_interrupted", True)
            monkeypatch.setattr(interrupt, "_signum", signal.SIGTERM)
            raise RuntimeError("encoder interrupted")
        return real(*args)
    monkeypatch.setattr(batch, "render_tile", terminated_after_one)
    r = run("teapot", *SIZE, "--turntable", 3, "-o", tmp_path / "spin.gif")
    assert r.exit_code == 143 and "terminated (SIGTERM): no animation written" in r.output
    assert list(tmp_path.iterdir()) == []


def test_tiles_and_workers_on_the_command_line_write_the_still(tmp_path):
    r = run("teapot", *SIZE, "-o", tmp_path / "still.png", "-q")
    assert r.exit_code == 0, r.output
    r = run("teapot", *SIZE, "--tiles", 7, "-o", tmp_path / "tiled.png", "-q")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "tiled.png").read_bytes() == (tmp_path / "still.png").read_bytes()
    r = run("teapot", *SIZE, "--turntable", 2, "--workers", 2, "-o", tmp_path / "d_%d.png")
    assert r.exit_code == 0, r.output
    assert "Worker 2: tiles, compile/load, render (s)" in r.output
    assert np.array_equal(pixels(tmp_path / "d_0.png"), pixels(tmp_path / "still.png"))


def test_ctrl_c_with_workers_stops_writes_nothing_and_closes_the_cluster(tmp_path):
    """A run on a local cluster it started, interrupted mid-way: exit 130,
    one line, no animation file, and none of its processes left behind."""
    import signal
    import subprocess
    import sys
    import time

    import psutil  # distributed's own dependency
    p = subprocess.Popen([sys.executable, "-m", "raytrace", "teapot", *SIZE, "--turntable", "5000",
                          "--workers", "2", "-o", "spin.gif", "-q"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    me = psutil.Process(p.pid)

    def workers():
        return [c for c in me.children(recursive=True) if "spawn_main" in " ".join(c.cmdline())]
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(workers()) < 2:
        time.sleep(0.2)
    time.sleep(2.0)              # frames under way
    cluster = me.children(recursive=True)   # the workers and multiprocessing's tracker
    assert len(workers()) == 2 and p.poll() is None
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert err.strip() == "interrupted: no animation written"
    assert list(tmp_path.iterdir()) == []
    _, alive = psutil.wait_procs(cluster, timeout=30)
    assert not alive, alive


@pytest.mark.parametrize("frames", [["--turntable", "2"], []])
def test_a_local_cluster_starts_while_the_scene_loads(tmp_path, monkeypatch, frames):
    """--workers: the cluster's start is under way (on its thread) when the
    scene loads, for frames and for a still, not begun after it; the render
    is the same."""
    import threading

    import raytrace.frames.distributed as distributed_module
    import raytrace.scene.load as load_module
    starting = threading.Event()
    real_cluster, real_load = distributed_module._local_cluster, load_module.load_scene

    def cluster(*args):
        starting.set()
        return real_cluster(*args)

    seen = []

    def load_scene(*args, **kwargs):
        seen.append(starting.wait(timeout=30))
        return real_load(*args, **kwargs)
    monkeypatch.setattr(distributed_module, "_local_cluster", cluster)
    monkeypatch.setattr(load_module, "load_scene", load_scene)
    out = tmp_path / ("d_%d.png" if frames else "d.png")
    r = run("teapot", *SIZE, *frames, "--workers", 1, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    assert seen == [True]
    r = run("teapot", *SIZE, "-o", tmp_path / "still.png", "-q")
    assert np.array_equal(pixels(tmp_path / ("d_0.png" if frames else "d.png")),
                          pixels(tmp_path / "still.png"))


def test_ctrl_c_while_the_scene_loads_closes_the_cluster_starting_meanwhile(tmp_path,
                                                                            monkeypatch):
    """--workers: a Ctrl-C while the scene loads (the cluster still starting
    on its thread) is the command's one line and exit 130, and the cluster's
    worker is gone when the command returns."""
    import os

    import psutil  # distributed's own dependency

    import raytrace.frames.distributed as distributed_module
    import raytrace.scene.load as load_module
    pids = []
    real_cluster = distributed_module._local_cluster

    def cluster(*args):
        c, client = real_cluster(*args)
        pids.extend(client.run(os.getpid).values())
        return c, client

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(distributed_module, "_local_cluster", cluster)
    monkeypatch.setattr(load_module, "load_scene", interrupted)
    r = run("teapot", *SIZE, "--turntable", 2, "--workers", 1, "-o", tmp_path / "spin.gif")
    assert r.exit_code == 130 and "interrupted: no animation written" in r.output
    assert len(pids) == 1
    assert not psutil.pid_exists(pids[0]) or psutil.Process(pids[0]).status() == "zombie"
    assert list(tmp_path.iterdir()) == []


def test_a_scene_that_fails_to_load_with_workers_is_one_line_and_leaves_no_process(tmp_path):
    """The cluster was starting while the scene failed to load: the error is
    the command's one line, and every process it started is gone."""
    import subprocess
    import sys
    import time

    import psutil  # distributed's own dependency
    (tmp_path / "bad.toml").write_text("[camera]\nposition = [0, 2]\n")
    p = subprocess.Popen([sys.executable, "-m", "raytrace", "bad.toml", "--turntable", "2",
                          "--workers", "2", "-o", "spin.gif", "-q"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    me = psutil.Process(p.pid)
    seen, workers = {}, set()
    while p.poll() is None:
        try:
            for c in me.children(recursive=True):
                seen[c.pid] = c
                if "spawn_main" in " ".join(_cmdline(c)):
                    workers.add(c.pid)
        except psutil.NoSuchProcess:
            break
        time.sleep(0.05)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 1, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "position" in err
    assert workers, "no worker started"
    _, alive = psutil.wait_procs(list(seen.values()), timeout=30)
    assert not alive, alive
    assert list(tmp_path.iterdir()) == [tmp_path / "bad.toml"]


def _cmdline(process):
    import psutil
    try:
        return process.cmdline()
    except psutil.Error:          # gone already
        return []
