"""Kernels compiled in a second process (kernels/ahead.py): when a first
render's shading stages (renderer/ahead.py) and a first ray query's kernel
(cast/ahead.py) start one, and how its entries join the cache."""
import subprocess
import sys

import numba
import pytest

from raytrace.kernels import ahead as core
from raytrace.kernels import kernel_cache
from raytrace.renderer import ahead


def _files(root, names):
    for name, text in names.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_what_the_second_process_compiled_is_adopted_data_first_where_missing(tmp_path,
                                                                              monkeypatch):
    ours = tmp_path / "ours" / "numba-abc"
    theirs = tmp_path / "theirs"
    _files(theirs / "numba-abc", {
        "kernels_x/wavefront.run_stage-347.py311.nbi": "index",
        "kernels_x/wavefront.run_stage-347.py311.1.nbc": "code",
        "kernels_x/shade.surface-28.py311.nbi": "surface index",
        "kernels_x/shade.surface-28.py311.1.nbc": "surface code",
        "kernels_x/ray.make_ray-40.py311.nbi": "their index",
        "kernels_x/ray.make_ray-40.py311.2.nbc": "their code"})
    # An entry this cache has already (this process compiled it too): left as it is.
    _files(ours, {"kernels_x/ray.make_ray-40.py311.nbi": "our index",
                  "kernels_x/ray.make_ray-40.py311.1.nbc": "our code"})
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(ours))
    copied = []
    real_replace = core.os.replace
    monkeypatch.setattr(core.os, "replace",
                        lambda a, b: (copied.append(b.name), real_replace(a, b)))
    core._adopt(theirs)
    got = {p.relative_to(ours).as_posix(): p.read_text() for p in ours.rglob("*")
           if p.is_file() and p.suffix != ".lock"}          # each copy is made under a lock
    assert {p.name for p in ours.rglob("*.lock")} == {
        f"{stem}.nbi.lock" for stem in ("wavefront.run_stage-347.py311", "shade.surface-28.py311",
                                        "ray.make_ray-40.py311")}
    assert got == {"kernels_x/wavefront.run_stage-347.py311.nbi": "index",
                   "kernels_x/wavefront.run_stage-347.py311.1.nbc": "code",
                   "kernels_x/shade.surface-28.py311.nbi": "surface index",
                   "kernels_x/shade.surface-28.py311.1.nbc": "surface code",
                   "kernels_x/ray.make_ray-40.py311.nbi": "our index",
                   "kernels_x/ray.make_ray-40.py311.1.nbc": "our code"}
    for stem in ("wavefront.run_stage-347.py311", "shade.surface-28.py311"):
        assert copied.index(f"{stem}.1.nbc") < copied.index(f"{stem}.nbi")


def test_the_second_process_starts_from_this_processs_entries_as_links(tmp_path, monkeypatch):
    """The second process's cache starts as hard links to this process's
    entries (kernels/ahead.py _seed), beside it: what is cached here loads
    there.  A file either process saves again replaces its own link, so the
    other cache keeps its file; and adopting skips what it did not save."""
    ours = tmp_path / "cache" / "numba-abc"
    _files(ours, {"kernels_x/shade.surface-28.py311.nbi": "surface index",
                  "kernels_x/shade.surface-28.py311.1.nbc": "surface code",
                  "kernels_x/shade.surface-28.py311.nbi.lock": ""})
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(ours))
    cache = core._cache_beside(ours)
    theirs = core.Path(cache) / "numba-abc"
    core._seed(theirs, ours)
    assert core.Path(cache).parent == ours.parent
    seeded = sorted(p.relative_to(theirs).as_posix() for p in theirs.rglob("*"))
    assert seeded == ["kernels_x", "kernels_x/shade.surface-28.py311.1.nbc",
                      "kernels_x/shade.surface-28.py311.nbi"]
    index = theirs / "kernels_x/shade.surface-28.py311.nbi"
    assert index.stat().st_ino == (ours / "kernels_x/shade.surface-28.py311.nbi").stat().st_ino
    merged = []
    monkeypatch.setattr(kernel_cache, "merge_index", lambda a, b: merged.append(a.name))
    core._adopt(core.Path(cache))
    assert merged == []                   # linked, not saved again: skipped
    (theirs / "kernels_x/new.nbi.tmp").write_text("their index")     # saved as Numba saves
    core.os.replace(theirs / "kernels_x/new.nbi.tmp", index)
    assert (ours / "kernels_x/shade.surface-28.py311.nbi").read_text() == "surface index"
    core._adopt(core.Path(cache))
    assert merged == ["shade.surface-28.py311.nbi"]      # saved there: merged here


def test_a_second_process_cache_left_a_day_ago_is_removed_at_the_next_launch(tmp_path):
    """A folder beside the cache from a process killed outright (no stop
    ran) goes when a later launch makes its own; a recent one, maybe a
    running process's, stays."""
    ours = tmp_path / "cache" / "numba-abc"
    ours.mkdir(parents=True)
    old, recent = ours.parent / "raytrace-ahead-old", ours.parent / "raytrace-ahead-recent"
    _files(old, {"numba-abc/kernels_x/a.nbi": "index"})
    recent.mkdir()
    day_ago = core.time.time() - core._STALE_S - 60
    core.os.utime(old, (day_ago, day_ago))
    made = core.Path(core._cache_beside(ours))
    assert not old.exists() and recent.exists() and made.parent == ours.parent


class _Finished:
    def poll(self):
        return 0

    def wait(self):
        return 1          # failed: nothing to adopt


@pytest.fixture
def started(monkeypatch):
    """The command lines of the second processes launched (none runs), in
    a process that has started none yet."""
    commands = []
    monkeypatch.setattr(core.subprocess, "Popen",
                        lambda *a, **k: commands.append(a[0]) or _Finished())
    monkeypatch.setattr(core.atexit, "register", lambda *a: None)
    monkeypatch.setattr(core, "_runs", {})
    return commands


def test_no_second_process_when_switched_off_or_the_stages_are_cached(monkeypatch, started):
    monkeypatch.setenv("RAYTRACE_COMPILE_AHEAD", "0")
    ahead.start(None)
    monkeypatch.delenv("RAYTRACE_COMPILE_AHEAD")
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: True)
    ahead.start(None)
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: False)
    monkeypatch.setattr(core.os, "cpu_count", lambda: 1)
    ahead.start(None)
    assert started == []
    # The control: a first run with two cores starts one, for the scene's
    # kind: the stages where the structure's ray kernels are cached.
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: True)
    ahead.start(None)
    assert len(started) == 1 and started[0][-6:] == ["raytrace.renderer.precompile", "0", "0", "0",
                                                     "-", "hard"]
    assert not ahead.compiles_rays()
    ahead.start(None)                   # once a process
    assert len(started) == 1
    core.stop("render")


def test_a_first_run_with_no_ray_kernel_compiles_them_in_the_second_process(monkeypatch,
                                                                            started):
    """Nothing cached, a structure with packets: the second process
    compiles the structure's ray kernels (this one the stages), until it
    is waited for."""
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: False)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: False)
    ahead.start(None, "whitted", "bvh", "soft")
    assert started[0][-6:] == ["raytrace.renderer.precompile", "0", "0", "0", "bvh", "soft"]
    assert ahead.compiles_rays()
    ahead.wait()
    assert not ahead.compiles_rays()


def test_a_structure_without_packets_has_its_stages_compiled_ahead(monkeypatch, started):
    """The grid's one-ray kernels are the smaller half of its first run:
    the second process compiles the stages, this one the ray kernels."""
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: False)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: False)
    ahead.start(None, "whitted", "grid", "hard")
    assert started[0][-6:] == ["raytrace.renderer.precompile", "0", "0", "0", "-", "hard"]
    assert not ahead.compiles_rays()
    core.stop("render")


def test_a_mirror_scenes_first_run_has_its_stages_compiled_ahead(monkeypatch, started):
    """Mirrors' and glass's stages are the larger half of a first BVH run:
    the second process compiles them, this one the ray kernels."""
    from raytrace.scene.kinds import tiny_scene
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: False)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: False)
    ahead.start(tiny_scene(False, True), "whitted", "bvh", "hard")
    assert started[0][-6:] == ["raytrace.renderer.precompile", "0", "1", "0", "-", "hard"]
    assert not ahead.compiles_rays()
    core.stop("render")


def test_a_mirror_scene_after_cached_stages_compiles_its_two_entries_in_two_processes(
        monkeypatch, started):
    """The stages cached, the mirror entries not: the second process
    compiles run_bounce_stage (last argument 0: not the shading), this one
    run_bounce_shade meanwhile; no second process for a scene without
    mirrors, or once the mirror entries are cached."""
    from raytrace.scene.kinds import tiny_scene
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: True)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: True)
    ahead.start(tiny_scene(False, True), "whitted", "bvh", "hard")
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached",
                        lambda *globs: not any("run_bounce" in g for g in globs))
    ahead.start(tiny_scene(False, False), "whitted", "bvh", "hard")
    assert started == [] and not ahead.shades_bounces_here()
    ahead.start(tiny_scene(False, True), "whitted", "bvh", "hard")
    assert started[0][-7:] == ["raytrace.renderer.precompile", "0", "1", "0", "-", "hard", "0"]
    assert ahead.shades_bounces_here() and not ahead.compiles_rays()
    ahead.wait()
    assert not ahead.shades_bounces_here()


def test_the_second_process_leaves_the_mirror_shading_to_the_first():
    """precompile.main with bounce_shade False (the job above) compiles the
    mirror entry's other steps and not its shading; a fresh process, so
    what this one has compiled does not count."""
    code = ("from raytrace.renderer import precompile\n"
            "from raytrace.kernels import bounces\n"
            "precompile.main(False, True, False, None, 'hard', False)\n"
            "print(len(bounces.run_bounce_stage.signatures),"
            " len(bounces.run_bounce_shade.signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["1", "0"]


def test_the_second_process_compiles_the_ray_kernels_the_render_runs():
    """Run in this process, the renderer's precompile.main adds the ray
    kernels' specialisations a first render (of another scene of the kind,
    with and without AOVs) would, and the render then adds none."""
    from raytrace.kernels import cast
    from raytrace.renderer import precompile
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import spheres
    precompile.main(False, False, False, "bvh", "hard")
    kernels = (cast._closest_block, cast._occluded_block)
    before = [list(k.signatures) for k in kernels]
    assert all(before)
    for aov in (False, True):
        render(spheres(), accel="bvh", shadows="hard", width=16, height=12, aov=aov)
    assert [list(k.signatures) for k in kernels] == before


def test_a_path_traced_first_run_compiles_the_path_stage_ahead(monkeypatch, started):
    """--integrator path: the second process compiles the path tracer's
    stage (PATH 1), whether or not Whitted's stages are cached, and none
    once the path stage is."""
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: True)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: True)
    ahead.start(None, "path")
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached",
                        lambda *globs: not any("run_path_shade" in g for g in globs))
    ahead.start(None, "path")
    assert len(started) == 1 and started[0][-6:] == ["raytrace.renderer.precompile", "0", "0", "1",
                                                     "-", "hard"]
    core.stop("render")


def test_each_structures_empty_layout_has_a_built_layouts_types():
    """cast/precompile.py compiles a first query's kernel for the
    structure's empty layout while the real one builds: the same types,
    or it would compile a kernel nobody calls."""
    import numpy as np

    from raytrace.accel.registry import STRUCTURES
    from raytrace.cast.rayscene import RayScene
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    f = np.array([[0, 1, 2], [0, 1, 3]])
    for name, structure in STRUCTURES.items():
        built = RayScene((v, f), accel=name)._built().acc
        assert numba.typeof(structure.empty_layout()) == numba.typeof(built), name


def test_the_second_process_compiles_the_kernel_the_first_query_runs():
    """Run in this process, precompile.main adds the one specialisation a
    first cast_rays (here brute force's, of one ray) would, and that call
    then adds none."""
    import numpy as np

    from raytrace.cast import precompile
    from raytrace.cast.rayscene import RayScene
    from raytrace.kernels import cast
    precompile.main("none", "closest", False)
    before = list(cast._closest_single.signatures)
    hits = RayScene((np.eye(3), np.array([[0, 1, 2]])), accel="none").cast_rays(
        [0.0, 0, 0], [1.0, 1, 1])
    assert hits.prim_id.tolist() == [0]
    assert list(cast._closest_single.signatures) == before


def test_a_first_query_starts_one_second_process_for_its_kernel(monkeypatch, started):
    from raytrace.cast import ahead as query_ahead
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *names: True)
    query_ahead.start("grid", "closest", 1)
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *names: False)
    query_ahead.start("grid", "occluded", 1000)
    assert len(started) == 1 and started[0][-5:] == ["raytrace.cast.precompile", "grid",
                                                     "occluded", "1", "0"]
    query_ahead.start("grid", "closest", 1)     # once a process
    assert len(started) == 1
    core.stop("query")


def test_a_cached_query_kernel_is_found_by_its_index_name():
    """cast/ahead.py tells a first run by a glob of the kernels' index
    files: once a query has run, the glob finds them (a wrong name would
    start a second process on every first query of a process, which then
    compiled from nothing what this process loads in a second)."""
    import numpy as np

    from raytrace.cast import ahead as query_ahead
    from raytrace.cast.rayscene import RayScene
    from raytrace.kernels.cachedir import kernel_cached
    from raytrace.kernels.jitconfig import CACHING
    assert CACHING
    scene = RayScene((np.eye(3), np.array([[0, 1, 2]])), accel="none")
    scene.cast_rays([0.0, 0, 0], [1.0, 1, 1])
    scene.occluded([0.0, 0, 0], [1.0, 1, 1])
    scene.count_intersections([0.0, 0, 0], [1.0, 1, 1])
    scene.list_intersections([0.0, 0, 0], [1.0, 1, 1])
    scene.distance([[1.0, 1, 1]])
    for query in ("closest", "occluded", "count", "list", "points"):
        assert kernel_cached(query_ahead._INDEX[query]), query
    assert not kernel_cached("cast._no_such_kernel-*.nbi")


def test_the_second_process_imports_this_processs_raytrace_from_any_directory(tmp_path,
                                                                              monkeypatch):
    """The README's first render runs in a clone, with raytrace installed
    elsewhere: the second process must compile the same files as this one
    (Numba's cache keys a kernel by its source file), not the working
    directory's copy, which ``python -m`` would import first."""
    import subprocess
    import sys

    import raytrace
    from raytrace.kernels import ahead
    (tmp_path / "raytrace").mkdir()
    (tmp_path / "raytrace" / "__init__.py").write_text("")    # another copy, in the way
    monkeypatch.chdir(tmp_path)
    where = [sys.executable, "-c", "import raytrace; print(raytrace.__file__)"]
    plain = subprocess.run(where, capture_output=True, text=True, check=True).stdout.strip()
    assert plain == str(tmp_path / "raytrace" / "__init__.py")      # what -m and -c do
    cache = tmp_path / "cache"
    cache.mkdir()
    child = subprocess.run(where, capture_output=True, text=True, check=True,
                           **ahead.child_setting(str(cache))).stdout.strip()
    assert child == raytrace.__file__


def test_a_kdtree_after_another_structure_compiles_its_rays_ahead(monkeypatch, started):
    """The stages cached, the kd-tree's traversal not: its ray kernels
    compile in the second process while this one compiles its builder; not
    for the grid (its builder compiles in less than the second process
    takes to start), nor once the kd-tree's traversal is cached."""
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: True)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *globs: True)
    looked = []
    monkeypatch.setattr("raytrace.kernels.cachedir.traversal_cached",
                        lambda module: looked.append(module) or module != "kdtree")
    ahead.start(None, "whitted", "grid", "hard")
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.traversal_cached", lambda module: True)
    ahead.start(None, "whitted", "kdtree", "hard")
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.traversal_cached",
                        lambda module: looked.append(module) or module != "kdtree")
    ahead.start(None, "whitted", "kdtree", "soft")
    assert looked == ["kdtree"]
    assert len(started) == 1 and started[0][-6:] == ["raytrace.renderer.precompile", "0", "0", "0",
                                                     "kdtree", "soft"]
    assert ahead.compiles_rays()
    core.stop("render")


def test_a_first_kdtree_query_after_another_structures_compiles_ahead(monkeypatch, started):
    from raytrace.cast import ahead as query_ahead
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *names: True)
    monkeypatch.setattr("raytrace.kernels.cachedir.traversal_cached",
                        lambda module: module != "kdtree")
    query_ahead.start("grid", "closest", 1)
    assert started == []
    query_ahead.start("kdtree", "closest", 1)
    assert len(started) == 1 and started[0][-5:] == ["raytrace.cast.precompile", "kdtree",
                                                     "closest", "0", "0"]
    core.stop("query")


def test_a_first_large_query_has_the_second_process_compile_the_ordering_too(monkeypatch, started):
    """A first call of ORDER_MIN rays or more may be put in order
    (cast/ordering.py): the second process compiles those kernels after
    its job, off this process's path."""
    from raytrace.cast import ahead as query_ahead
    from raytrace.cast.ordering import ORDER_MIN
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *names: False)
    query_ahead.start("bvh", "closest", ORDER_MIN)
    assert len(started) == 1 and started[0][-5:] == ["raytrace.cast.precompile", "bvh",
                                                     "builder", "1", "1"]
    core.stop("query")


def test_a_kernel_cached_in_both_has_the_second_processs_entries_merged(tmp_path):
    """A function in both caches (every structure's closest-hit kernel is
    one): the entries ours lacks join its index, each data file signed for
    its new name, so both load; ours stay as they were, and an index of
    another source stamp adds nothing."""
    from raytrace.kernels.kernel_cache import CheckedCacheFile, merge_index
    base = "cast.block-73.py311"
    ours_dir, theirs_dir, stale_dir = (tmp_path / n for n in ("ours", "theirs", "stale"))
    for d in (ours_dir, theirs_dir, stale_dir):
        d.mkdir()
    ours = CheckedCacheFile(str(ours_dir), base, (1.0, 10))
    theirs = CheckedCacheFile(str(theirs_dir), base, (1.0, 10))
    ours.save(("bvh",), "bvh code")
    theirs.save(("kdtree",), "kdtree code")       # their data file 1, as ours is
    theirs.save(("bvh",), "their bvh code")
    theirs.save(("grid",), "grid code")
    merge_index(theirs_dir / f"{base}.nbi", ours_dir / f"{base}.nbi")
    merged = CheckedCacheFile(str(ours_dir), base, (1.0, 10))
    assert {k: merged.load(k) for k in [("bvh",), ("kdtree",), ("grid",)]} == {
        ("bvh",): "bvh code", ("kdtree",): "kdtree code", ("grid",): "grid code"}
    assert sorted(p.name for p in ours_dir.glob("*.nbc")) == [f"{base}.{i}.nbc" for i in (1, 2, 3)]
    stale = CheckedCacheFile(str(stale_dir), base, (2.0, 10))
    stale.save(("lbvh",), "stale code")
    merge_index(stale_dir / f"{base}.nbi", ours_dir / f"{base}.nbi")
    assert CheckedCacheFile(str(ours_dir), base, (1.0, 10)).load(("lbvh",)) is None


_SAME_KERNEL = """
import numpy as np
from raytrace.accel.bvh import points
from raytrace.cast import precompile
from raytrace.cast.rayscene import RayScene
from raytrace.kernels import cast
blocks = {"count": cast._counts_block, "list": cast._listing_block,
          "points": points._points_block}
scene = RayScene((np.eye(3), np.array([[0, 1, 2]])), accel="bvh")
calls = {"count": lambda: scene.count_intersections([[0.0, 0, 0]] * 3, [1.0, 1, 1]),
         "list": lambda: scene.list_intersections([[0.0, 0, 0]] * 3, [1.0, 1, 1]),
         "points": lambda: scene.closest_points([[1.0, 1, 1]] * 3)}
for query, block in blocks.items():
    precompile.main("bvh", query, False)
    after = list(block.signatures)
    calls[query]()
    print(query, len(after), list(block.signatures) == after)
"""


def test_the_second_process_compiles_the_count_list_and_point_kernels_the_queries_run():
    """In a process of its own (no specialisation loaded yet), precompile.main
    loads or compiles one specialisation of each of these queries'
    kernels, and a first call then adds none: the one the query runs."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", _SAME_KERNEL], capture_output=True, text=True,
                         check=True).stdout.split("\n")
    assert out[:3] == ["count 1 True", "list 1 True", "points 1 True"]


def test_a_first_query_sends_the_shorter_compile_to_the_second_process(monkeypatch, started):
    """A first query's kernel compiles in the second process while this one
    compiles the builder and builds, or, where the kernel is the longer
    (the BVH's counting, listing and packet kernels), here before the
    build while the second process compiles the builder, adopted before
    the build."""
    import numpy as np

    from raytrace.cast import ahead as query_ahead
    from raytrace.cast import precompile
    from raytrace.cast.rayscene import RayScene
    monkeypatch.setattr(core.os, "cpu_count", lambda: 2)
    monkeypatch.setattr("raytrace.kernels.cachedir.kernel_cached", lambda *names: False)
    events = []
    monkeypatch.setattr(core, "wait", lambda key: events.append("wait"))
    monkeypatch.setattr(precompile, "main", lambda *a: events.append(("here",) + a))
    built = RayScene._built

    def building(self, *a, **k):
        events.append("build" if self._prepared is None else "built")
        return built(self, *a, **k)

    monkeypatch.setattr(RayScene, "_built", building)
    mesh = (np.eye(3), np.array([[0, 1, 2]]))
    many = [[0.0, 0, 0]] * 100
    calls = [("bvh", "count", lambda s: s.count_intersections([0.0, 0, 0], [1.0, 1, 1])),
             ("bvh", "list", lambda s: s.list_intersections([0.0, 0, 0], [1.0, 1, 1])),
             ("bvh", "closest", lambda s: s.cast_rays(many, [1.0, 1, 1])),
             ("bvh", "closest", lambda s: s.cast_rays([0.0, 0, 0], [1.0, 1, 1])),
             ("bvh", "points", lambda s: s.distance([[1.0, 1, 1]])),
             ("grid", "count", lambda s: s.count_intersections([0.0, 0, 0], [1.0, 1, 1])),
             ("bvh", "count", lambda s: s.signed_distance([[1.0, 1, 1], [0.1, 0.1, 0.1]]))]
    for accel, query, call in calls:
        monkeypatch.setattr(core, "_runs", {})
        started.clear()
        events.clear()
        call(RayScene(mesh, accel=accel))
        here = accel == "bvh" and (query in ("count", "list") or call is calls[2][2])
        assert [c[-4:-2] for c in started] == [[accel, "builder" if here else query]], query
        assert events[:3] == (["build", ("here", accel, query, call is calls[2][2]), "wait"]
                              if here else ["build", "wait"]), (accel, query)
        assert query_ahead._pending == {}
    core.stop("query")
