"""Helpers without machine code of their own (kernels/linked_only.py): which
libraries are, what their cache entries hold, and that answers are the
bits Numba's own compile gives."""
import json
import os
import subprocess
import sys

import numpy as np
from numba.core import codegen

from raytrace.kernels import (
    jitconfig,  # noqa: F401 -- installs linked_only, as the kernels do
    linked_only,
)


def _library(dispatcher):
    return next(iter(dispatcher.overloads.values())).library


def _scene_and_rays():
    from raytrace import RayScene
    from raytrace.scene.builtin import teapot_mesh
    mesh = teapot_mesh(detail=4)
    rng = np.random.default_rng(5)
    o = rng.normal(size=(40, 3)) * 4.0
    d = rng.normal(size=(40, 3))
    return RayScene((mesh.vertices, mesh.faces)), o, d


def test_installed_on_this_numba():
    """The Numba installed has the code library this patches: if a release
    changes it, install() leaves Numba alone and this says so."""
    assert linked_only.installed()
    assert codegen.JITCodeLibrary.finalize is linked_only._finalize


def _helper_and_caller():
    """A fresh, uncached copy of a helper of ours (kernels/ray.py's ray_at)
    and a caller with a Python wrapper, both compiled here."""
    from numba import njit

    from raytrace.kernels.jit import JIT
    from raytrace.kernels.ray import ray_at
    helper = njit(**dict(JIT, cache=False))(ray_at.py_func)

    @njit
    def caller(origins, dirs, t_min, i):
        return helper(origins, dirs, t_min, i).inv_x

    rows = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    dirs = np.array([[4.0, 1.0, 1.0], [1.0, 2.0, 3.0]])
    assert caller(rows, dirs, np.zeros(2), 1) == 1.0
    assert caller(rows, dirs, np.zeros(2), 0) == 0.25
    return helper, caller


def test_helpers_are_ir_only_and_their_callers_machine_code():
    helper, caller = _helper_and_caller()
    assert getattr(_library(helper), "_ir_only", False)
    assert not getattr(_library(caller), "_ir_only", False)


def test_a_helper_cache_entry_is_its_ir_and_loads_as_ir_only():
    helper, _ = _helper_and_caller()
    library = _library(helper)
    state = library.serialize_using_object_code()
    assert state[1] == "bitcode"
    loaded = codegen.JITCodeLibrary._unserialize(library.codegen, state)
    assert loaded._ir_only and loaded._finalized
    linked = loaded._get_module_for_linking()
    assert {f.name for f in linked.functions if not f.is_declaration} == \
        {f.name for f in library._final_module.functions if not f.is_declaration}


def test_numba_functions_not_of_raytrace_are_left_as_numba_has_them():
    from numba import njit

    @njit(no_cpython_wrapper=True, no_cfunc_wrapper=True)
    def other(x):
        return x + 1.0

    @njit
    def caller(x):
        return other(x) * 2.0

    assert caller(1.5) == 5.0
    assert not getattr(_library(other), "_ir_only", False)


_ANSWERS = """
import json, sys, numpy as np
sys.path.insert(0, {tests!r})
from test_linked_only import _answers
print(json.dumps(_answers()))
"""


def _answers():
    """This process's patch flag, and the hits of _scene_and_rays' rays and a
    small spheres render as hex strings."""
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import spheres
    scene, o, d = _scene_and_rays()
    hits = scene.cast_rays(o, d)
    image = render(spheres(), accel="bvh", shadows="hard", width=24, height=16).linear
    return [linked_only.installed(), hits.t.tobytes().hex(), hits.prim_id.tolist(),
            hits.u.tobytes().hex(), image.tobytes().hex()]


def test_answers_are_the_bits_of_numbas_own_compile(tmp_path):
    """The same rays and render here (helpers without machine code) and in a
    fresh process compiling as Numba does (RAYTRACE_LINKED_ONLY=0, an empty
    cache): the same hits, distances, barycentrics and image, bit for bit."""
    env = dict(os.environ, RAYTRACE_LINKED_ONLY="0", RAYTRACE_QUIET="1",
               NUMBA_CACHE_DIR=str(tmp_path), RAYTRACE_COMPILE_AHEAD="0")
    run = subprocess.run([sys.executable, "-c", _ANSWERS.format(tests=os.path.dirname(__file__))],
                         env=env, capture_output=True, text=True, check=True)
    theirs = json.loads(run.stdout.splitlines()[-1])
    ours = _answers()
    assert ours[0] is True and theirs[0] is False
    assert ours[1:] == theirs[1:]
