"""Vertex normals: split at creases, angle-weighted, never NaN."""
import math

import numpy as np
import pytest
import trimesh

from raytrace.scene.flatten import cross_rows, unit_rows
from raytrace.scene.normals import (
    crease_normals,
    equal_rows,
    face_normals,
    file_normals,
    shading_normals,
)

# Every test with the kernels compiled and as Python (conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_and_python")

libm_atan2 = np.frompyfunc(math.atan2, 2, 1)


def same_triangles(v, f, v2, f2):
    """The triangles of (v2, f2) are those of (v, f), bit for bit."""
    return f.shape == f2.shape and np.array_equal(v[f], v2[f2])


def test_cube_keeps_its_edges():
    box = trimesh.creation.box()
    v, f, n = crease_normals(box.vertices, box.faces)
    assert len(v) == 24 and same_triangles(box.vertices, box.faces, v, f)
    # Every corner's normal is its face's normal, and there are six of them.
    assert np.array_equal(n[f], np.repeat(face_normals(v, f)[:, None], 3, axis=1))
    assert len(np.unique(n, axis=0)) == 6


def test_triangle_soup_is_smoothed_like_a_welded_mesh():
    """An STL file repeats each vertex for every face: faces still meet
    where their corners have the same coordinates."""
    s = trimesh.creation.icosphere(subdivisions=2)
    soup_v, soup_f = s.vertices[s.faces].reshape(-1, 3), np.arange(3 * len(s.faces)).reshape(-1, 3)
    v, f, n = crease_normals(soup_v, soup_f)
    assert same_triangles(soup_v, soup_f, v, f)
    assert np.allclose(n[f], crease_normals(s.vertices, s.faces)[2][s.faces], rtol=0, atol=1e-15)


@pytest.mark.parametrize("expected", [None, 1])
def test_equal_rows_number_values_by_first_appearance(expected):
    """The hash table's welding (scene/weld.py) against NumPy's sort: rows
    with many repeats, in a table crowded enough that probes pass other
    values, row counts either side of the rows it hashes ahead, and a
    table grown from 16 slots."""
    rng = np.random.default_rng(7)
    for n in (1, 5, 17, 40_000):
        a = rng.integers(0, 12, (n, 3)).astype(np.float64)
        ids, values, count = equal_rows(a, values=expected)
        _, where, inverse = np.unique(a, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(where)
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        assert count == len(where)
        assert np.array_equal(ids, rank[inverse.reshape(-1)])
        assert np.array_equal(values, a[where[order]]) and values.dtype == a.dtype


def test_sphere_is_smooth():
    s = trimesh.creation.icosphere(subdivisions=4, radius=2.0)
    v, f, n = crease_normals(s.vertices, s.faces)
    assert np.array_equal(v, s.vertices) and np.array_equal(f, s.faces)   # nothing split
    radial = v / np.linalg.norm(v, axis=1, keepdims=True)
    # Each face normal is within ~half an edge's angle (about 2 degrees here)
    # of the radial direction; their weighted mean at a vertex is far closer.
    assert np.degrees(np.arccos(np.clip((n * radial).sum(axis=1), -1, 1))).max() < 0.5
    # Bit for bit the NumPy sum of each corner's angle times its face's unit
    # normal, in corner order (the kernels make each face's once).  The
    # angles by libm's atan2, as the kernels' are: NumPy's own arctan2 on an
    # AVX-512 machine differs from it in the last bit.
    e1, e2, e3 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 1]]
    cross = cross_rows(e1, e2)
    area2 = np.sqrt(sum(cross[:, k] * cross[:, k] for k in range(3)))
    dots = [sum(a[:, k] * b[:, k] for k in range(3)) for a, b in ((e1, e2), (e1, e3), (e2, e3))]
    angles = libm_atan2(area2[:, None], np.stack([dots[0], -dots[1], dots[2]], axis=1)).astype(float)
    summed = np.zeros_like(v)
    np.add.at(summed, f.ravel(), (angles[:, :, None] * unit_rows(cross)[:, None, :]).reshape(-1, 3))
    assert np.array_equal(n, unit_rows(summed))


@pytest.mark.parametrize("angle, crease, split", [(20, 35, False), (40, 35, True), (40, 45, False),
                                                  (90, 180, False), (10, 0, True)])
def test_hinge_splits_beyond_the_crease(angle, crease, split):
    """Two triangles on a shared edge, folded by ``angle`` degrees."""
    a = np.radians(angle)
    v = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [-np.cos(a), 0, np.sin(a)]], dtype=float)
    f = np.array([[0, 2, 1], [0, 1, 3]])   # both wound to face +z when flat
    v2, f2, n = crease_normals(v, f, crease)
    assert len(v2) == (6 if split else 4) and same_triangles(v, f, v2, f2)
    if not split:   # the hinge's normal bisects the fold
        assert np.allclose(n[0], [np.sin(a / 2), 0, np.cos(a / 2)])


def test_angle_weighting_ignores_how_a_face_is_cut():
    """A cube corner's normal is the diagonal whether a side is one
    triangle or a fan of three (Thürmer & Wüthrich 1998); by area it would
    lean towards the cut side."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0.2, 0.8, 0]], float)
    whole = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2]])
    cut = np.array([[0, 4, 1], [0, 5, 4], [0, 2, 5], [0, 1, 3], [0, 3, 2]])
    for faces in (whole, cut):
        _, f, n = crease_normals(v, faces, crease=180)
        assert np.allclose(n[0], -np.ones(3) / np.sqrt(3), atol=1e-12)


def test_degenerate_faces_give_no_nan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [2, 0, 0]], float)
    f = np.array([[0, 1, 2], [0, 1, 3], [3, 4, 3], [1, 3, 4]])   # three without area
    for crease in (0, 35, 180):
        v2, f2, n = crease_normals(v, f, crease)
        assert np.isfinite(n).all() and same_triangles(v, f, v2, f2)
        assert np.allclose(n[f2[0]], [0, 0, 1])


def test_opposed_faces_fall_back_to_a_face_normal():
    """Two faces back to back on the same vertices: with crease 180 they
    join, their normals cancel, and the face normal is used, not zero."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    _, f, n = crease_normals(v, np.array([[0, 1, 2], [0, 2, 1]]), crease=180)
    assert np.allclose(np.abs(n[f]), [0, 0, 1])


def test_file_normals_are_normalised_and_zero_ones_replaced():
    box = trimesh.creation.box()
    given = np.array(box.vertices) * 3.0           # outward, not unit
    given[0] = 0.0
    given[1] = np.nan
    n = file_normals(box.vertices, box.faces, given)
    unit = box.vertices / np.linalg.norm(box.vertices, axis=1, keepdims=True)
    assert np.allclose(n[2:], unit[2:], rtol=0, atol=1e-15)
    # The zero and NaN ones: the angle-weighted normal there, the diagonal.
    assert np.allclose(n[:2], unit[:2], atol=1e-12)



def test_a_replaced_file_normal_is_the_computed_one_bit_for_bit():
    """On a smooth sphere a missing file normal is replaced by what
    crease_normals makes there: one way to make corner angles, so a
    machine whose NumPy arctan2 is not libm's (AVX-512) gives the same."""
    s = trimesh.creation.icosphere(subdivisions=3)
    _, _, computed = crease_normals(s.vertices, s.faces)
    given = np.array(computed)
    given[::7] = 0.0
    assert np.array_equal(file_normals(s.vertices, s.faces, given)[::7], computed[::7])

def test_shading_normals_choices():
    box = trimesh.creation.box()
    assert shading_normals(box.vertices, box.faces, flat=True)[2] is None
    given = np.array(box.vertices)
    v, f, n = shading_normals(box.vertices, box.faces, normals=given)
    assert len(v) == 8 and np.allclose(np.linalg.norm(n, axis=1), 1)
    assert len(shading_normals(box.vertices, box.faces)[0]) == 24


def test_cross_rows_are_np_cross_bit_for_bit():
    from raytrace.scene.flatten import cross_rows
    rng = np.random.default_rng(7)
    a = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-150, 150, (500, 1))
    b = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-150, 150, (500, 1))
    a[:5] = 0.0
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        want, got = np.cross(a, b), cross_rows(a, b)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert np.array_equal(cross_rows(a[:1], b).view(np.int64), np.cross(a[:1], b).view(np.int64))


def test_unit_rows_of_zero_tiny_and_huge_rows():
    """unit_rows: a row whose squares stay in range is divided by
    np.linalg.norm's sum, bit for bit, whatever rows surround it; a zero
    row stays zero; tiny and huge rows are scaled first, then made unit."""
    rng = np.random.default_rng(5)
    v = rng.standard_normal((1000, 3))
    odd = [3, 500, 999]
    v[odd] = [[0.0, 0.0, 0.0], [1e-200, 0.0, 3e-201], [1e200, -1e200, 0.0]]
    u = unit_rows(v)
    plain = np.setdiff1d(np.arange(len(v)), odd)
    assert np.array_equal(u[plain], v[plain] / np.linalg.norm(v[plain], axis=1)[:, None])
    assert np.array_equal(u[3], np.zeros(3))
    assert np.allclose(u[[500, 999]], [[1 / np.sqrt(1.09), 0, 0.3 / np.sqrt(1.09)],
                                       [np.sqrt(0.5), -np.sqrt(0.5), 0]], rtol=0, atol=1e-15)
