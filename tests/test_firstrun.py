"""The compile notice: one line on stderr when Numba really compiles (a cold
cache), none when every kernel loads from the cache, none when quiet."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

NOTICE = "compiling kernels for"

TOY = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[1])
    from raytrace.renderer.firstrun import expecting

    import toy
    with expecting("a toy", 3):
        toy.double(2.0)
        toy.triple(2.0)        # a second compile: still one line
    print("done")
""")


def _run(args, cache, **env):
    full = {k: v for k, v in os.environ.items() if k != "RAYTRACE_QUIET"}
    full.update(NUMBA_CACHE_DIR=str(cache), **env)
    return subprocess.run(args, capture_output=True, text=True, env=full, timeout=600)


@pytest.fixture
def toy(tmp_path):
    (tmp_path / "toy.py").write_text(textwrap.dedent("""
        from numba import njit

        @njit(cache=True)
        def double(x):
            return 2 * x

        @njit(cache=True)
        def triple(x):
            return 3 * x
    """))
    script = tmp_path / "run.py"
    script.write_text(TOY)
    return [sys.executable, str(script), str(tmp_path)]


def test_cold_cache_says_what_it_compiles_once_then_warm_is_silent(toy, tmp_path):
    cache = tmp_path / "cache"
    cold = _run(toy, cache)
    assert cold.returncode == 0, cold.stderr
    lines = [ln for ln in cold.stderr.splitlines() if NOTICE in ln]
    assert lines == ["compiling kernels for a toy (first run only, about 3 s)"], cold.stderr
    warm = _run(toy, cache)
    assert warm.returncode == 0 and warm.stdout.strip() == "done", warm.stderr
    assert NOTICE not in warm.stderr


def test_quiet_environment_silences_the_notice(toy, tmp_path):
    cold = _run(toy, tmp_path / "cache", RAYTRACE_QUIET="1")
    assert cold.returncode == 0, cold.stderr
    assert NOTICE not in cold.stderr


def test_the_command_is_silent_when_its_kernels_are_cached(tmp_path):
    """The suite's own cache: the first run may compile (and say so, once),
    the second loads every kernel and says nothing; -q never says it."""
    cache = os.environ.get("NUMBA_CACHE_DIR") or tmp_path / "cache"
    cmd = [sys.executable, "-m", "raytrace", "spheres", "--width", "16", "--height", "12"]
    first = _run([*cmd, "-o", str(tmp_path / "a.png")], cache)
    assert first.returncode == 0, first.stderr
    assert sum(NOTICE in ln for ln in first.stderr.splitlines()) <= 1
    second = _run([*cmd, "-o", str(tmp_path / "b.png")], cache)
    assert second.returncode == 0, second.stderr
    assert NOTICE not in second.stderr, second.stderr
    quiet = _run([*cmd, "-q", "--shadows", "none", "--spp", "2", "-o", str(tmp_path / "c.png")],
                 cache)
    assert quiet.returncode == 0 and NOTICE not in quiet.stderr, quiet.stderr


def test_estimate_counts_mirrors_and_textures():
    from raytrace.renderer.firstrun import BOUNCES_S, RENDER_S, VARIANT_S, scene_estimate
    from raytrace.scene.model import Camera, Material, Scene, Sphere
    plain = Scene("s", Camera((0, 0, 5), (0, 0, 0)), [Sphere((0, 0, 0), 1.0)])
    mirror = Scene("m", Camera((0, 0, 5), (0, 0, 0)), [Sphere((0, 0, 0), 1.0, Material(reflect=0.5))])
    a, b = scene_estimate(plain, "kdtree"), scene_estimate(mirror, "kdtree")
    # A cache with render kernels in it makes both a variant's estimate.
    assert (a, b) in ((RENDER_S["kdtree"], RENDER_S["kdtree"] + BOUNCES_S), (VARIANT_S, VARIANT_S))


def test_cache_dir_is_found_without_numba_and_tells_a_first_run(tmp_path, monkeypatch):
    """cachedir.py names the directory jitconfig gives Numba; no render
    kernel index in it means a first run, told before Numba loads."""
    import numba

    import raytrace.kernels.jitconfig  # noqa: F401 -- sets numba.config.CACHE_DIR
    from raytrace.kernels import cachedir
    from raytrace.renderer import firstrun
    assert str(cachedir.cache_dir(numba.__version__)) == numba.config.CACHE_DIR
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("RAYTRACE_QUIET", raising=False)
    assert not cachedir.render_kernel_cached()
    monkeypatch.setitem(firstrun._state, "shown", False)
    monkeypatch.setitem(firstrun._state, "quiet", False)
    import io
    err = io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    firstrun.announce_if_cold("teapot: bvh, hard shadows", 14)
    firstrun.announce_if_cold("again", 1)                       # once per process
    assert err.getvalue() == "compiling kernels for teapot: bvh, hard shadows (first run only, about 14 s)\n"
    # A cache only path-traced renders filled: warm, not a first run.
    path_index = cachedir.cache_dir(numba.__version__) / "kernels_x" / "pathtrace.run_path_stage-94.py311.nbi"
    path_index.parent.mkdir(parents=True)
    path_index.touch()
    assert not cachedir.render_kernel_cached() and cachedir.any_render_kernel_cached()
    monkeypatch.setitem(firstrun._state, "shown", False)
    firstrun.announce_if_cold("warm from path", 1)
    assert "warm from path" not in err.getvalue()
    path_index.unlink()
    index = cachedir.cache_dir(numba.__version__) / "kernels_x" / "wavefront.run_stage-481.py311.nbi"
    index.touch()
    assert cachedir.render_kernel_cached()
    monkeypatch.setitem(firstrun._state, "shown", False)
    firstrun.announce_if_cold("warm", 1)
    assert "warm" not in err.getvalue()


def test_a_warm_render_never_works_out_a_compile_estimate(monkeypatch):
    """The estimate reads the render kernel's cache index, as the kernel's
    load does: a render that compiles nothing does not read it a second time."""
    import raytrace
    from raytrace.renderer import firstrun
    raytrace.render("spheres", width=8, height=6)      # its kernels loaded (or compiled) here
    calls = []
    monkeypatch.setattr(firstrun, "has_cache_entries", lambda d: calls.append(d) or True)
    raytrace.render("spheres", width=8, height=6)
    assert calls == []


def test_an_estimate_worked_out_when_the_compile_starts_is_in_the_notice(monkeypatch):
    import io

    from raytrace.renderer import firstrun
    monkeypatch.setitem(firstrun._state, "shown", False)
    monkeypatch.setitem(firstrun._state, "quiet", False)
    monkeypatch.delenv("RAYTRACE_QUIET", raising=False)
    err = io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    asked = []
    with firstrun.expecting("a toy", lambda: asked.append(1) or 7):
        assert asked == []
        firstrun._compile_started(None)
    assert asked == [1]
    assert err.getvalue() == "compiling kernels for a toy (first run only, about 7 s)\n"


@pytest.fixture
def cold(tmp_path, monkeypatch):
    """An empty kernel cache and a notice not yet shown in this process."""
    import raytrace.kernels.jitconfig  # noqa: F401 -- Numba's own cache stays the suite's
    from raytrace.renderer import firstrun
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "empty"))
    monkeypatch.delenv("RAYTRACE_QUIET", raising=False)
    monkeypatch.setitem(firstrun._state, "shown", False)
    monkeypatch.setitem(firstrun._state, "quiet", False)
    return tmp_path


def test_a_garbage_file_gets_its_error_alone(cold):
    """No 'compiling ... about 14 s' before 'not a readable PLY mesh': the
    file's first bytes are read before the notice (CliRunner, cold cache)."""
    from click.testing import CliRunner

    from raytrace.cli.main import main
    bad = cold / "bad.ply"
    bad.write_text("garbage\n")
    result = CliRunner().invoke(main, [str(bad), "-o", str(cold / "bad.png")])
    assert result.exit_code == 1
    assert result.stderr == f"Error: {bad}: not a readable PLY mesh (Not a ply file!)\n"


def test_the_early_notice_reads_the_file_and_the_integrator(cold, capsys):
    """Good files of each format pass looks_like_mesh; garbage and a bad
    scene file get no notice; --integrator path, or a scene file's
    integrator = "path", gets the path tracer's estimate."""
    import trimesh

    from raytrace.cli.main import _announce_first_run
    from raytrace.renderer import firstrun
    from raytrace.scene.assets import assets_dir
    from raytrace.scene.formats.mesh import looks_like_mesh
    box = trimesh.creation.box()
    good = [assets_dir() / "toys.obj", assets_dir() / "palette.ply"]
    for ext in ("stl", "off", "glb", "gltf", "ply"):
        good.append(cold / f"box.{ext}")
        box.export(good[-1])
    (cold / "ascii.stl").write_bytes(trimesh.exchange.stl.export_stl_ascii(box).encode())
    assert all(looks_like_mesh(p) for p in [*good, cold / "ascii.stl"])
    for ext in ("obj", "ply", "stl", "off", "glb", "gltf"):
        (cold / f"bad.{ext}").write_text("garbage\n")
        assert not looks_like_mesh(cold / f"bad.{ext}")
    (cold / "bad.toml").write_text("camera = [\n")
    (cold / "path.toml").write_text('integrator = "path"\n')

    def notice(scene, kind, **options):
        firstrun._state["shown"] = False
        _announce_first_run(str(scene), kind, options)
        return capsys.readouterr().err

    assert notice(cold / "bad.ply", "mesh") == notice(cold / "bad.toml", "toml") == ""
    whitted = firstrun.command_estimate("bvh", None)
    # A small mesh file's kernels run as Python (kernels/uncompiled.py); a
    # large one's compile.
    assert notice(good[1], "mesh") == ("compiling kernels for palette.ply: bvh, hard shadows "
                                       f"(first run only, about {whitted} s)\n")
    trimesh.creation.icosphere(5).export(cold / "large.stl")
    assert (cold / "large.stl").stat().st_size > firstrun.SMALL_MESH_BYTES
    assert notice(cold / "large.stl", "mesh") == (
        "compiling kernels for large.stl: bvh, hard shadows "
        f"(first run only, about {whitted + firstrun.MESH_S} s)\n")
    path = f"path tracer (first run only, about {firstrun.PATH_S} s)\n"
    assert notice("teapot", "builtin", integrator="path").endswith(f"hard shadows, {path}")
    assert notice(cold / "path.toml", "toml").endswith(f"path.toml: bvh, hard shadows, {path}")
    assert notice(cold / "path.toml", "toml", integrator="whitted").endswith(f"about {whitted} s)\n")


def test_a_path_traced_render_estimates_the_path_stage(monkeypatch):
    """raytrace.render's notice: a path-traced scene's estimate is the path
    tracer's (mirrors included in its one stage), textures adding theirs."""
    from raytrace.renderer import firstrun
    from raytrace.scene.model import Camera, Material, Mesh, Scene, Sphere
    monkeypatch.setattr(firstrun, "has_cache_entries", lambda dispatcher: False)
    mirror = Scene("m", Camera((0, 0, 5), (0, 0, 0)), [Sphere((0, 0, 0), 1.0, Material(reflect=0.5))])
    uv = Mesh(np.eye(3), np.array([[0, 1, 2]]), uv=np.zeros((3, 2)))
    textured = Scene("t", Camera((0, 0, 5), (0, 0, 0)), [uv])
    assert firstrun.scene_estimate(mirror, "kdtree") == firstrun.RENDER_S["kdtree"] + firstrun.BOUNCES_S
    assert firstrun.scene_estimate(mirror, "kdtree", "path") == firstrun.PATH_S
    assert firstrun.scene_estimate(textured, "bvh", "path") == firstrun.PATH_S + firstrun.TEXTURES_S


def test_a_first_query_announces_its_own_kernels_estimate(monkeypatch):
    """A RayScene's first query sets the notice's estimate by the kernel it
    compiles: the BVH's packets for many rays, counting, listing, a point
    query's BVH on another structure."""
    import numpy as np

    from raytrace.cast.rayscene import RayScene
    from raytrace.renderer import firstrun
    monkeypatch.setenv("RAYTRACE_COMPILE_AHEAD", "0")
    said = []
    monkeypatch.setattr(firstrun, "expect", lambda what, seconds=None: said.append(seconds))
    mesh = (np.eye(3), np.array([[0, 1, 2]]))
    cases = [("bvh", "closest", 1, firstrun.QUERY_S["bvh"]),
             ("bvh", "occluded", 1000, firstrun.BVH_QUERY_S["packets"]),
             ("bvh", "count", 1, firstrun.BVH_QUERY_S["count"]),
             ("bvh", "points", 1, firstrun.POINTS_S["bvh"]),
             ("grid", "list", 1, firstrun.QUERY_S["grid"] + firstrun.COUNT_S),
             ("grid", "points", 1, firstrun.POINTS_OTHER_S)]
    for accel, query, n_rays, seconds in cases:
        RayScene(mesh, accel=accel)._built(query, n_rays)
        assert said[-1] == seconds, (accel, query)
