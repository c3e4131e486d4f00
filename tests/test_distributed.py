"""Tiles and frames (raytrace/frames/batch.py), here and on a local Dask cluster of
two worker processes (raytrace/frames/distributed.py): byte for byte the still
render, counters summed exactly, a killed worker changes nothing, and a
missing extra is one line."""
import json
import os
import signal
import sys

import numpy as np
import pytest

import raytrace
from raytrace import RaytraceError
from raytrace.frames.batch import InProcess, Tasks, animate, bands, render_frames, render_tiled
from raytrace.kernels.wavefront import TILE
from raytrace.renderer.driver import RenderOptions
from raytrace.scene.animation import turntable

# The options other tests compile kernels for (tests/test_determinism.py):
# soft shadows and several samples a pixel use the hashed random numbers.
pytestmark = pytest.mark.filterwarnings("ignore:Port .* is already in use")
SOFT = dict(shadows="soft", light_samples=16, spp=4, seed=2024, width=48, height=36)
HARD = dict(width=64, height=48)


@pytest.fixture(scope="module")
def scene():
    return raytrace.load_scene("teapot", width=64, height=48)


@pytest.fixture(scope="module")
def cluster():
    import logging

    import distributed  # the test extra installs it
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=logging.ERROR) as c, \
            distributed.Client(c) as client:
        yield client


def test_bands_cover_the_rows_once_in_whole_strips():
    for h, n in ((48, 5), (7, 7), (3, 10), (1, 1), (50, 3), (65, 9)):
        b = bands(h, n)
        assert b[0][0] == 0 and b[-1][1] == h
        assert all(y1 == next_y0 for (_, y1), (next_y0, _) in zip(b, b[1:]))
        assert all(y1 > y0 and y0 % TILE == 0 for y0, y1 in b)
        assert len(b) == min(n, -(-h // TILE))


@pytest.mark.parametrize("opts", [HARD, SOFT], ids=["hard", "soft"])
def test_tiles_here_are_the_still_byte_for_byte_with_the_same_counters(scene, opts):
    still = raytrace.render(scene, **opts)
    tiled = raytrace.render(scene, tiles=5, **opts)
    assert tiled.image.dtype == np.uint8 and np.array_equal(tiled.image, still.image)
    assert tiled.stats["counters"] == still.stats["counters"]
    assert tiled.stats["tiles"] == 5 and tiled.stats["frames"] == 1


def test_turntable_frames_here_first_is_the_still_and_counters_add_up(scene):
    cams = turntable(scene.camera, 3)
    frames, stats = animate(scene, cams, RenderOptions(**HARD), tiles=2)
    assert len(frames) == 3
    assert np.array_equal(frames[0], raytrace.render(scene, **HARD).image)
    assert not np.array_equal(frames[0], frames[1])       # the camera moved
    total = {}
    for cam in cams:
        one = raytrace.render(raytrace.scene.model.Scene(**{**scene.__dict__, "camera": cam}), **HARD)
        for k, v in one.stats["counters"].items():
            total[k] = total.get(k, 0) + v
    assert stats["counters"] == total
    assert stats["frames"] == 3 and stats["tiles"] == 2


def test_skipped_frames_are_not_rendered(scene):
    seen = []
    render_frames(scene, turntable(scene.camera, 4), RenderOptions(**HARD), InProcess(1),
                  skip={0, 2}, on_frame=lambda i, image: seen.append(i))
    assert seen == [1, 3]


def test_dask_tiles_and_frames_are_the_local_render_byte_for_byte(scene, cluster):
    from raytrace.frames.distributed import DaskRunner
    still = raytrace.render(scene, **SOFT)
    on_dask = raytrace.render(scene, client=cluster, **SOFT)
    assert np.array_equal(on_dask.image, still.image)
    assert on_dask.stats["counters"] == still.stats["counters"]
    # 4 a worker, 2 workers: 8 asked, as many as whole 8-row strips allow.
    assert on_dask.stats["tiles"] == len(bands(SOFT["height"], 8)) == 5
    assert len(on_dask.stats["workers"]) == 2               # both took part
    cams = turntable(scene.camera, 4)
    here, _ = animate(scene, cams, RenderOptions(**HARD))
    there, stats = animate(scene, cams, RenderOptions(**HARD), runner=DaskRunner(cluster, 1),
                           tiles=3)
    assert all(np.array_equal(a, b) for a, b in zip(here, there))
    assert stats["time"]["overhead_s"] >= 0 and stats["frames"] == 4


def test_small_tiles_share_a_task_and_still_come_back_in_order(scene, cluster):
    """24 small frames on 2 workers: 3 frames a Dask task (each task costs
    ~7 ms of scheduling), the frames the same and in order."""
    from raytrace.frames.distributed import DaskRunner, _group_size
    from raytrace.renderer.driver import prepare
    cams = turntable(scene.camera, 24)
    payload = prepare(scene, RenderOptions(**HARD)).payload()
    assert _group_size(24, HARD["height"], payload, 2) == 3
    assert _group_size(8, HARD["height"], payload, 2) == 1           # too few to share
    here, _ = animate(scene, cams, RenderOptions(**HARD))
    order = []
    there, stats = animate(scene, cams, RenderOptions(**HARD), runner=DaskRunner(cluster, 1),
                           progress=lambda done, total: order.append(done))
    assert all(np.array_equal(a, b) for a, b in zip(here, there))
    assert order == list(range(1, 25))
    assert sum(w["tiles"] for w in stats["workers"].values()) == 24


def test_scheduler_option_uses_a_running_cluster(scene, cluster, tmp_path, monkeypatch):
    """`--scheduler ADDRESS` (here through DASK_SCHEDULER_ADDRESS): the
    cluster's workers render the tiles; the image is the still's.  Which of
    them gets these 6 tasks of ~3 ms is Dask's choice (a worker still
    unpickling the scene may get none: seen once in CI); that both take
    part is tested above, with longer tasks."""
    from click.testing import CliRunner

    from raytrace.cli.main import main
    size = ["--width", str(HARD["width"]), "--height", str(HARD["height"])]
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", cluster.scheduler.address)
    r = CliRunner().invoke(main, ["teapot", *size, "-o", str(tmp_path / "d.png"), "--json"])
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    tiles = len(bands(HARD["height"], 8))          # 8 asked; 6 strips of 8 rows
    assert stats["tiles"] == tiles == 6
    assert set(stats["workers"]) <= set(cluster.scheduler_info()["workers"])
    assert sum(w["tiles"] for w in stats["workers"].values()) == tiles
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS")
    r = CliRunner().invoke(main, ["teapot", *size, "-o", str(tmp_path / "s.png"), "-q"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "d.png").read_bytes() == (tmp_path / "s.png").read_bytes()


def test_missing_extra_is_one_line(monkeypatch):
    from raytrace.frames.distributed import connect
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(RaytraceError, match=r"distributed extra: pip install 'raytrace\[distributed\]'"):
        with connect(workers=2):
            pass


def test_a_task_that_fails_on_a_worker_is_one_raytrace_error(scene, cluster):
    from raytrace.frames.distributed import DaskRunner
    from raytrace.renderer.driver import Payload
    bad = Payload(*(None,) * 11)            # not a scene's buffers: the worker's kernel call fails
    with pytest.raises(RaytraceError, match="a Dask worker failed"):
        list(DaskRunner(cluster, 1).run(bad, Tasks([scene.camera], [0], [(0, 4)], 16, 12)))


def test_tiled_render_has_no_linear_image_and_refuses_aovs(scene):
    assert render_tiled(scene, RenderOptions(**HARD), None, 2).linear is None
    with pytest.raises(RaytraceError, match="aov=True"):
        raytrace.render(scene, tiles=2, aov=True, **HARD)


def test_dask_arrays_of_rays_give_the_one_batch_answers(scene, cluster):
    """Block by block, on Dask's threads (several kernels would run at once
    without the kernel lock: Numba's workqueue aborts the process) and on
    the cluster's processes."""
    import dask.array as da

    from raytrace.frames.distributed import cast_rays, occluded
    mesh = next(o for o in scene.objects if hasattr(o, "faces"))
    rays = raytrace.RayScene((mesh.vertices, mesh.faces))
    rng = np.random.default_rng(7)
    o = rng.normal(size=(5000, 3)) * 3
    d = rng.normal(size=(5000, 3)) - o
    want = rays.cast_rays(o, d)
    got = cast_rays(rays, da.from_array(o, chunks=(701, 3)), da.from_array(d, chunks=(701, 3)))
    assert set(got) == set(raytrace.cast.results.RayHits.FIELDS)
    for name, lazy in got.items():
        np.testing.assert_array_equal(lazy.compute(scheduler="threads"), want[name])
    assert 0 < want.hit.sum() < len(o)
    np.testing.assert_array_equal(cluster.compute(got["prim_id"]).result(), want.prim_id)
    # One result type: read as a RayHits is, lazily or computed in one pass.
    done = got.compute(scheduler="threads")
    np.testing.assert_array_equal(done.hit, want.hit)
    np.testing.assert_array_equal(got.hit.compute(scheduler="threads"), want.hit)
    np.testing.assert_array_equal(done.normal, want.normal)
    np.testing.assert_array_equal(done["object_id"], want.object_id)
    blocked = occluded(rays, da.from_array(o, chunks=1000), da.from_array(d, chunks=1000), t_max=1.0)
    np.testing.assert_array_equal(cluster.compute(blocked).result(),
                                  rays.occluded(o, d, t_max=1.0))
    with pytest.raises(RaytraceError, match=r"\(n, 3\)"):
        cast_rays(rays, da.zeros((4, 2)), da.zeros((4, 2)))


def test_in_a_fresh_process_a_layout_finds_its_traversal_and_dask_stays_out(scene):
    """One new process, two checks.  A Dask worker gets the structure's
    layout by unpickling, which imports its structure's package and so
    registers its traversal (else, with a cold cache, the render kernel
    compiles against nothing: "no traversal registered").  And frames and tiles rendered here never
    import Dask (half a second)."""
    import pickle
    import subprocess

    from raytrace.renderer.driver import prepare
    acc = prepare(scene, RenderOptions(**HARD)).acc
    code = ("import pickle, sys, numba\n"
            "acc = pickle.loads(sys.stdin.buffer.read())\n"
            "assert 'raytrace.accel.bvh.traverse' in sys.modules\n"
            "from raytrace.kernels.query import CLOSEST, _traversal\n"
            "closest = _traversal(numba.typeof(acc), CLOSEST)\n"
            "print(closest.__module__)\n"
            "import raytrace\n"
            "from raytrace.frames.batch import animate\nfrom raytrace.scene.animation import turntable\n"
            "from raytrace.renderer.driver import RenderOptions\n"
            "s = raytrace.load_scene('teapot', width=16, height=12)\n"
            "animate(s, turntable(s.camera, 2), RenderOptions(width=16, height=12), tiles=2)\n"
            "raytrace.render(s, tiles=3, width=16, height=12)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))\n")
    p = subprocess.run([sys.executable, "-c", code], input=pickle.dumps(acc),
                       capture_output=True, timeout=120)
    assert p.returncode == 0, p.stderr.decode()
    assert p.stdout.decode().split() == ["raytrace.accel.bvh.traverse", "[]"]


class _LosesTheScene:
    """A Dask client in this process whose tasks on the first scattered
    scene come back cancelled, as when a worker's death takes the
    scattered data with it (dask/distributed#3149): the runner must send
    the scene again and rerun those tiles."""

    class Future:
        def __init__(self, value=None, lost=False):
            self.value, self.lost = value, lost

        def result(self):
            if self.lost:
                from distributed.client import FutureCancelledError
                raise FutureCancelledError("key", reason="already forgotten")
            return self.value

        def cancel(self):
            pass

    def __init__(self):
        self.scatters = []

    def wait_for_workers(self, n, timeout):
        pass

    def scheduler_info(self):
        return {"workers": {"a": {}, "b": {}}}

    def scatter(self, payload, broadcast, hash):
        self.scatters.append(payload)
        return len(self.scatters)          # the key: which scatter

    def submit(self, fn, shared, threads, tiles, pure):
        if shared == 1:
            return self.Future(lost=True)
        return self.Future(fn(self.scatters[shared - 1], threads, tiles))


def test_a_lost_scattered_scene_is_sent_again_and_changes_nothing(scene):
    from raytrace.frames.distributed import DaskRunner
    cams = turntable(scene.camera, 3)
    here, _ = animate(scene, cams, RenderOptions(**HARD))
    client = _LosesTheScene()
    there, _ = animate(scene, cams, RenderOptions(**HARD), runner=DaskRunner(client, 1), tiles=2)
    assert len(client.scatters) == 2            # once, then once again for every lost task
    assert all(np.array_equal(a, b) for a, b in zip(here, there))


def test_a_worker_killed_mid_render_changes_nothing(scene, cluster):
    """Last in this file: it kills one of the shared cluster's workers (its
    nanny starts another)."""
    from raytrace.frames.distributed import DaskRunner
    cams = turntable(scene.camera, 6)
    here, _ = animate(scene, cams, RenderOptions(**SOFT))
    killed = []

    def kill_one(done, total):
        if not killed:          # after the first frame: the other tasks are in flight
            victim = sorted(cluster.run(os.getpid).values())[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    there, _ = animate(scene, cams, RenderOptions(**SOFT), runner=DaskRunner(cluster, 1),
                       tiles=2, progress=kill_one)
    assert killed and killed[0] not in cluster.run(os.getpid).values()
    assert all(np.array_equal(a, b) for a, b in zip(here, there))


def _render_kernels():
    """On a worker: the render kernels' specialisations loaded or compiled
    there (the shading stages' entry, and the mirror-and-glass kernel), by
    kernel."""
    from raytrace.kernels.bounces import run_bounce_stage
    from raytrace.kernels.wavefront import run_stage
    return {k.__name__: sorted(str(s) for s in k.signatures)
            for k in (run_stage, run_bounce_stage)}


def test_workers_warm_up_the_kernel_their_tiles_use():
    """`--workers`' warm-up (cli/warmup.py's worker_payload, sent by
    DaskRunner.warm before the structure is built): each worker holds the
    render kernel before its first tile, and it is the one the tiles use
    (no specialisation is added by the frames), for a mirrored scene and a
    plain one; each worker reports its warm-up."""
    import logging

    import distributed

    from raytrace.cli.warmup import worker_payload
    from raytrace.frames.distributed import DaskRunner
    # The kernels go into the cache here first: from an empty cache, both
    # workers would compile the mirror kernel at once (twice the work, on
    # cores the other tests share).  The workers still start without them.
    for name in ("whitted", "teapot"):
        raytrace.render(raytrace.load_scene(name, width=32, height=24), **HARD)
    # A cluster of its own: the other tests' renders load kernels on theirs.
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=logging.ERROR) as c, \
            distributed.Client(c) as client:
        before = client.run(_render_kernels)
        assert len(before) == 2 and all(not any(k.values()) for k in before.values())
        for name in ("teapot", "whitted"):
            sc = raytrace.load_scene(name, width=32, height=24)
            runner = DaskRunner(client, 1, warm_up=worker_payload)
            runner.warm(sc, RenderOptions(**HARD))
            distributed.wait([f for _, f in runner._warming])
            warmed = client.run(_render_kernels)
            # The plain scene's stages are run_stage's; the mirrored one's
            # add run_bounce_stage to run_stage's of the same types.
            expected = {"run_stage": 1, "run_bounce_stage": int(name == "whitted")}
            assert all({k: len(v) for k, v in warmed[w].items()} == expected
                       for w in before), (before, warmed)
            _, stats = animate(sc, turntable(sc.camera, 4), RenderOptions(**HARD), runner=runner)
            assert client.run(_render_kernels) == warmed
            # Each worker asked is listed, with a tile or not (None: still warming at the end).
            assert set(stats["workers"]) == set(warmed)
            assert all(w["warmup_s"] is None or w["warmup_s"] > 0 for w in stats["workers"].values())
            before = warmed
