import compileall
import os
import sys
from pathlib import Path

import pytest

# The suite starts some 130 processes that import raytrace (commands, Dask
# workers).  Where Python writes no bytecode (PYTHONDONTWRITEBYTECODE), each
# would compile raytrace's modules from source again, 0.25 s a process:
# compiled here once, as an installed package has them.
if sys.dont_write_bytecode:
    compileall.compile_dir(Path(__file__).resolve().parents[1] / "raytrace", quiet=1)

from raytrace.renderer.driver import render
from raytrace.scene.builtin import spheres, teapot

# No compile notice (raytrace/firstrun.py) in the suite: CliRunner mixes
# stderr into the output that --json tests parse, and which test compiles
# first depends on the order.  tests/test_firstrun.py tests the notice.
os.environ["RAYTRACE_QUIET"] = "1"

# Small images keep the suite fast once the kernels are compiled; the
# teapot still covers a few thousand pixels.
W, H = 96, 72


@pytest.fixture(scope="session")
def teapot_scene():
    return teapot()


@pytest.fixture(scope="session")
def spheres_scene():
    return spheres()


@pytest.fixture(scope="session")
def render_small():
    cache = {}

    def go(scene, **kw):
        key = (scene.name, tuple(sorted(kw.items())))
        if key not in cache:
            kw.setdefault("width", W)
            kw.setdefault("height", H)
            cache[key] = render(scene, **kw)
        return cache[key]
    return go


def scene_file_error(path):
    """The message of the RaytraceError read_scene_file(path) raises,
    checked to be one line that starts with the file's name."""
    from raytrace.errors import RaytraceError
    from raytrace.scene.formats.scenefile import read_scene_file
    with pytest.raises(RaytraceError) as info:
        read_scene_file(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: "), msg
    assert "\n" not in msg
    return msg


@pytest.fixture(params=["compiled", "python"])
def compiled_and_python(request, monkeypatch):
    """The test twice: the mesh readers' build kernels compiled, then run as
    Python as a small mesh's first read runs them (kernels/uncompiled.py)."""
    from raytrace.kernels import uncompiled
    compiled = request.param == "compiled"
    monkeypatch.setattr(uncompiled, "runs_compiled", lambda kernel, n: compiled)
