"""A first render's shading stages compiled in a second process
(renderer/ahead.py): when it starts, and how its entries join the cache."""
import numba

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
    real_replace = ahead.os.replace
    monkeypatch.setattr(ahead.os, "replace",
                        lambda a, b: (copied.append(b.name), real_replace(a, b)))
    ahead._adopt(theirs)
    got = {p.relative_to(ours).as_posix(): p.read_text() for p in ours.rglob("*") if p.is_file()}
    assert got == {"kernels_x/wavefront.run_stage-347.py311.nbi": "index",
                   "kernels_x/wavefront.run_stage-347.py311.1.nbc": "code",
                   "kernels_x/shade.surface-28.py311.nbi": "surface index",
                   "kernels_x/shade.surface-28.py311.1.nbc": "surface code",
                   "kernels_x/ray.make_ray-40.py311.nbi": "our index",
                   "kernels_x/ray.make_ray-40.py311.1.nbc": "our code"}
    for stem in ("wavefront.run_stage-347.py311", "shade.surface-28.py311"):
        assert copied.index(f"{stem}.1.nbc") < copied.index(f"{stem}.nbi")


class _Finished:
    def poll(self):
        return 0


def test_no_second_process_when_switched_off_or_the_stages_are_cached(monkeypatch):
    started = []
    monkeypatch.setattr(ahead.subprocess, "Popen",
                        lambda *a, **k: started.append(a[0]) or _Finished())
    monkeypatch.setattr(ahead.atexit, "register", lambda *a: None)
    monkeypatch.setitem(ahead._ahead, "process", None)
    monkeypatch.setenv("RAYTRACE_COMPILE_AHEAD", "0")
    ahead.start(None)
    monkeypatch.delenv("RAYTRACE_COMPILE_AHEAD")
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: True)
    ahead.start(None)
    assert started == []
    monkeypatch.setattr("raytrace.kernels.cachedir.render_kernel_cached", lambda: False)
    monkeypatch.setattr(ahead.os, "cpu_count", lambda: 1)
    ahead.start(None)
    assert started == []
    # The control: a first run with two cores starts one, for the scene's kind.
    monkeypatch.setattr(ahead.os, "cpu_count", lambda: 2)
    ahead.start(None)
    assert len(started) == 1 and started[0][-3:] == ["raytrace.renderer.precompile", "0", "0"]
    ahead.start(None)                   # once a process
    assert len(started) == 1
    ahead._stop(ahead._ahead["process"])
