import numpy as np
import pytest

import raytrace.scenes.teapot as teapot_module
from raytrace.flatten import degenerate_mask, flatten
from raytrace.scenes.builtin import teapot
from raytrace.scenes.teapot import _ROWS, _bernstein, _surface_points, load_patches, tessellate


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
