"""A small mesh's weld and crease split, run as Python on a first run
(kernels/uncompiled.py), give the compiled kernels' bits."""
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
import trimesh
from numba import njit

from raytrace.kernels import uncompiled
from raytrace.kernels.lowlevel import (
    double_from_bits,
    leading_zeros,
    load_word,
    trailing_zeros,
    wide_product,
)
from raytrace.scene.creases import SMALL_FAN
from raytrace.scene.normals import crease_split, equal_rows, face_frames


def _bits(a):
    a = np.asarray(a)
    return a.view(np.uint64) if a.dtype == np.float64 else a


def _both(monkeypatch, func, *args, **kw):
    """func(*args, **kw) with the kernels compiled, then run as Python."""
    answers = []
    for compiled in (True, False):
        monkeypatch.setattr(uncompiled, "runs_compiled", lambda kernel, n, c=compiled: c)
        answers.append([_bits(a) for a in func(*args, **kw)])
    return answers


def _meshes():
    rng = np.random.default_rng(7)
    ball = trimesh.creation.icosphere(subdivisions=2)
    bumped = ball.vertices * (1 + 0.2 * rng.random((len(ball.vertices), 1)))
    # An STL's soup: every face's corners repeated, faces meeting by position.
    soup = bumped[ball.faces].reshape(-1, 3), np.arange(3 * len(ball.faces)).reshape(-1, 3)
    box = trimesh.creation.box()
    # A cone whose apex has more faces than SMALL_FAN (its edges paired by
    # sorting), with a degenerate face and a face used twice.
    cone = trimesh.creation.cone(radius=1.0, height=0.5, sections=3 * SMALL_FAN)
    cf = np.vstack([cone.faces, [[0, 0, 1]], cone.faces[:1]])
    return [(bumped, ball.faces), soup, (box.vertices, box.faces), (cone.vertices, cf)]


@pytest.mark.parametrize("keep", [False, True])
@pytest.mark.parametrize("crease", [0.0, 35.0, 180.0])
def test_the_crease_split_run_as_python_gives_the_compiled_bits(monkeypatch, keep, crease):
    for v, f in _meshes():
        compiled, python = _both(monkeypatch, crease_split, v, f, crease, keep=keep)
        assert all(np.array_equal(a, b) for a, b in zip(compiled, python))
        compiled, python = _both(monkeypatch, face_frames, v, f)
        assert all(np.array_equal(a, b) for a, b in zip(compiled, python))


def test_equal_rows_run_as_python_gives_the_compiled_numbers(monkeypatch):
    rng = np.random.default_rng(3)
    rows = rng.integers(0, 40, (3000, 3)).astype(np.float64) / 7
    rows[::50] = -0.0          # -0.0 and 0.0 differ bit for bit
    rows[1::50] = 0.0
    rows[2::97] = np.nan
    # From a table for 16 values: it grows several times on the way.  The
    # hash's multiplies wrap, as compiled, without a warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compiled, python = _both(monkeypatch, equal_rows, rows, values=16)
    assert all(np.array_equal(a, b) for a, b in zip(compiled, python))
    assert compiled[2] < len(rows)


def test_a_kernel_runs_compiled_when_compiled_already_or_for_large_inputs():
    from raytrace.scene.creases import fan_groups
    assert uncompiled.runs_compiled(fan_groups, uncompiled.UNCOMPILED_MAX + 1)
    from numba import njit

    @njit
    def fresh(x):
        return x + 1
    assert not uncompiled.runs_compiled(fresh, 1)       # never compiled, not cached
    assert uncompiled.chosen(fresh, 1)(2) == 3 and not fresh.signatures
    fresh(1)
    assert uncompiled.runs_compiled(fresh, 1)


def _printed_with_empty_caches(code, tmp_path):
    """The last word ``code`` prints, run in a fresh process with empty
    kernel caches under tmp_path."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), XDG_CACHE_HOME=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.split()[-1]


def test_a_first_run_compiles_nothing_to_read_small_mesh_files(tmp_path):
    """Empty caches: a PLY without normals (welded and split at creases), an
    OBJ naming materials (trimesh's), a plain OBJ, an ASCII and a binary STL
    and a PLY of mixed polygons are read without compiling."""
    assets = os.path.join(os.path.dirname(__file__), os.pardir, "assets")
    ball = trimesh.creation.icosphere(2)
    ball.export(tmp_path / "ball.stl")
    (tmp_path / "ascii.stl").write_text(trimesh.exchange.stl.export_stl_ascii(ball))
    # A binary PLY of a quad and a triangle: mixed polygons, read record by record.
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n"
            "property float y\nproperty float z\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n")
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 2, 0.5]], "<f4")
    faces = bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes()
    faces += bytes([3]) + np.array([3, 2, 4], "<i4").tobytes()
    (tmp_path / "mixed.ply").write_bytes(head.encode() + corners.tobytes() + faces)
    files = [os.path.join(assets, name) for name in ("textured.toml", "house.obj")]
    files += [str(tmp_path / name) for name in ("ball.stl", "ascii.stl", "mixed.ply")]
    code = (
        "from raytrace.scene.load import load_scene\n"
        f"for path in {files!r}:\n"
        "    load_scene(path)\n"
        "from raytrace.scene import creases, weld\n"
        "from raytrace.scene.formats import objtext, polygons\n"
        "print(sum(len(k.signatures) for k in (creases.fan_groups, creases.fan_normals,\n"
        "      creases.face_frames, creases.corner_lists, weld.number_rows, objtext.parse_lines,\n"
        "      polygons.polygon_lists)))\n")
    assert _printed_with_empty_caches(code, tmp_path) == "0"


@njit
def _intrinsics(a, b, data, out, doubles):
    for i in range(len(a)):
        out[i, 0], out[i, 1] = wide_product(a[i], b[i])
        out[i, 2] = leading_zeros(a[i])
        out[i, 3] = trailing_zeros(b[i])
        out[i, 4] = load_word(data, i)
        doubles[i] = double_from_bits(a[i])


def test_the_intrinsics_stand_ins_answer_as_the_intrinsics():
    """Python's versions of kernels/lowlevel.py's intrinsics (the OBJ
    kernel's word loads, bit counts and 128-bit products, the weld's
    prefetch) against the compiled ones."""
    from raytrace.kernels import lowlevel as low
    rng = np.random.default_rng(5)
    n = 2000
    shifts = rng.integers(0, 64, n).astype(np.uint64)
    a = rng.integers(0, 2 ** 64, n, np.uint64, endpoint=False) >> shifts
    b = rng.integers(0, 2 ** 64, n, np.uint64, endpoint=False) << shifts
    a[:3], b[:3] = [0, 2 ** 64 - 1, 1], [2 ** 64 - 1, 0, 2 ** 63]
    data = rng.integers(0, 256, n + 8, np.uint8)
    out, doubles = np.empty((n, 5), np.uint64), np.empty(n)
    _intrinsics(a, b, data, out, doubles)
    stand = {k: uncompiled._stand_ins()[id(getattr(low, k))] for k in (
        "wide_product", "leading_zeros", "trailing_zeros", "load_word", "double_from_bits",
        "prefetch")}
    wide = data.astype(np.int64)             # the kernel's bytes as Python reads them
    for i in range(n):
        assert [int(x) for x in stand["wide_product"](a[i], b[i])] == out[i, :2].tolist()
        assert stand["leading_zeros"](a[i]) == out[i, 2]
        assert stand["trailing_zeros"](b[i]) == out[i, 3]
        assert stand["load_word"](wide, i) == out[i, 4]
        assert stand["double_from_bits"](a[i]).view(np.uint64) == doubles[i].view(np.uint64) == a[i]
        assert stand["prefetch"](wide, i) is None


def test_decimal_to_double_as_python_gives_the_compiled_doubles():
    from raytrace.kernels.parse_float import POWERS_OF_FIVE, decimal_to_double
    from tests.test_parse_float import convert, decimals
    cases = decimals(np.random.default_rng(11), 400)
    ms = np.array([m for m, *_ in cases], np.int64)
    qs = np.array([q for _, q, *_ in cases], np.int64)
    compiled = np.empty(len(cases))
    convert(ms, qs, POWERS_OF_FIVE, compiled)
    python = uncompiled.as_python(decimal_to_double)
    with np.errstate(over="ignore"):
        got = np.array([python(m, q, POWERS_OF_FIVE) for m, q in zip(ms, qs)])
    assert np.array_equal(got.view(np.uint64), compiled.view(np.uint64))
    assert (compiled < 0).any() and (compiled > 0).any()     # some declined, most read


def test_within_compiled_always_a_kernel_runs_compiled():
    @njit
    def fresh(x):
        return x + 1
    with uncompiled.compiled_always():
        assert uncompiled.runs_compiled(fresh, 1) and uncompiled.chosen(fresh, 1) is fresh
    assert not uncompiled.runs_compiled(fresh, 1)


def test_warmup_compiles_the_readers_kernels_from_an_empty_cache(tmp_path):
    """`raytrace warmup`'s loading step compiles the weld and the crease
    split on its one triangle, which a first read would run as Python."""
    code = (
        "from raytrace.cli.warmup import _loading\n"
        "_loading()\n"
        "from raytrace.scene import creases, weld\n"
        "print(min(len(k.signatures) for k in (weld.number_rows, creases.corner_lists,\n"
        "      creases.face_frames, creases.fan_groups, creases.fan_normals)))\n")
    assert _printed_with_empty_caches(code, tmp_path) == "1"
