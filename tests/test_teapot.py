import numpy as np
import pytest

import raytrace.scene.teapot as teapot_module
from raytrace.scene.builtin import teapot
from raytrace.scene.flatten import degenerate_mask, flatten
from raytrace.scene.teapot import _ROWS, _bernstein, _surface_points, load_patches, tessellate


def test_default_tessellation_is_the_workshop_size():
    v, f, n = tessellate(4)
    assert len(f) == 32 * 4 * 4 * 2 == 1024
    dropped = degenerate_mask(v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]).sum()
    assert dropped == 32           # the lid knob's and the bottom's pole fans
    assert flatten(teapot())[2]["triangles"] == 992


def test_detail_43_gives_about_118k_triangles():
    v, f, n = tessellate(43)
    assert len(f) == 32 * 43 * 43 * 2 == 118336


def test_normals_point_outwards():
    v, f, n = tessellate(4)
    vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
    assert vol > 0                  # consistent outward winding
    # Vertex normals agree with the faces around them.
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ok = np.linalg.norm(fn, axis=1) > 0
    agree = np.einsum("ij,ij->i", fn[ok], n[f[ok, 0]]) > 0
    assert agree.mean() > 0.99


def test_surface_points_are_einsums_sum_bit_for_bit():
    # detail 100: 10,201 (u, v) pairs, so more than one block of _ROWS.
    patches, cps = load_patches()
    b = _bernstein(np.linspace(0.0, 1.0, 101))
    ctrl = cps[patches].reshape(-1, 4, 4, 3)
    assert 101 * 101 > _ROWS
    assert np.array_equal(_surface_points(b, ctrl), np.einsum("ui,vj,pijk->puvk", b, b, ctrl))


def test_welding_the_seams_leaves_no_two_vertices_coincident():
    for detail in (1, 2, 4, 7):
        v, f, n = tessellate(detail)
        assert len(np.unique(np.round(v, 9) + 0.0, axis=0)) == len(v)
        assert np.array_equal(np.unique(f), np.arange(len(v)))   # every vertex used


@pytest.mark.parametrize("chunk", [1 << 18, 1000])
def test_vertex_normals_are_the_corner_sums_bit_for_bit(chunk, monkeypatch):
    """np.add.at's sums of np.cross's face normals, normalised by
    np.linalg.norm; with chunks of 1,000 faces the 3,136 faces' normals
    take four."""
    monkeypatch.setattr(teapot_module, "_CHUNK", chunk)
    v, f, n = tessellate(7)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, f[:, k], fn)
    ln = np.linalg.norm(vn, axis=1, keepdims=True)
    assert np.array_equal(n, np.divide(vn, ln, out=np.zeros_like(vn), where=ln > 0))


def _same(want, got):
    return all(a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
               for a, b in zip(want, got))


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("detail", [1, 2, 7, 40])
def test_big_tessellations_kernels_give_the_numpy_paths_bits(detail, threads):
    """scene/tessellate.py (--detail 125 and up) against the NumPy path:
    vertices, their order, faces and normals, bit for bit."""
    want = tessellate(detail)
    patches, cps = load_patches()
    b = _bernstein(np.linspace(0.0, 1.0, detail + 1))
    got = teapot_module._tessellate_parallel(b, cps[patches].reshape(-1, 4, 4, 3), detail, threads)
    assert _same(want, got)


def test_tessellate_takes_the_kernels_from_kernel_min(monkeypatch):
    calls = []
    real = teapot_module._tessellate_parallel
    monkeypatch.setattr(teapot_module, "_tessellate_parallel",
                        lambda *a: calls.append(a[2]) or real(*a))
    want = tessellate(9)            # 5,184 triangles
    assert calls == []
    monkeypatch.setattr(teapot_module, "KERNEL_MIN", 5_184)
    assert _same(want, tessellate(9)) and calls == [9]
    tessellate(8)                   # 4,096 triangles: NumPy
    assert calls == [9]


def test_the_command_counts_the_tessellation_kernels_as_compile_time():
    """load.load_kernels loads them before the teapot is loaded, for the
    details that run them only."""
    from raytrace.scene.load import load_kernels
    assert load_kernels("teapot", 125) > 0            # 1,000,000 triangles
    assert load_kernels("teapot", 124) == 0.0
    assert load_kernels("teapot", None) == load_kernels("spheres", 200) == 0.0
    assert load_kernels("teapot", True) == load_kernels("teapot", 10**9) == 0.0   # load_scene's errors


def test_importing_numba_is_not_counted_as_the_tessellation_kernels_load():
    """In a new process Numba is first imported for the tessellation (0.3-0.6 s):
    load_kernels imports it before its clock starts, so a warm `--detail 128`
    reports loading, not compiling (the kernel call itself stubbed here)."""
    import subprocess
    import sys
    code = ("import sys, raytrace.scene.teapot as t\n"
            "assert 'numba' not in sys.modules\n"
            "seen = []\n"
            "t._tessellate_parallel = lambda *a: seen.append('numba' in sys.modules)\n"
            "t.load_kernels(125)\n"
            "print(seen)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["[True]"]
