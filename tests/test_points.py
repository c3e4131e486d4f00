"""closest_points, distance and signed_distance against a slow reference."""
import numpy as np
import pytest

from raytrace import RayScene, RaytraceError
from raytrace.scene.model import Camera, Plane, Scene, Sphere
from tests.structures import STRUCTURES
from tests.test_crossings import box


def seg_dist2(p, a, b):
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    c = a + t[:, None] * ab
    return np.einsum("ij,ij->i", p - c, p - c)


def reference_d2(v, f, q):
    """Squared distance from each point to the mesh: the plane of each face
    where the projection falls inside it, else the nearest edge."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    out = np.empty(len(q))
    for i, p in enumerate(q):
        pp = np.broadcast_to(p, a.shape)
        h = np.einsum("ij,ij->i", pp - a, n)
        proj = pp - h[:, None] * n
        inside = np.ones(len(a), bool)
        for x, y in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(y - x, proj - x), n) >= 0
        d2 = np.minimum(np.minimum(seg_dist2(pp, a, b), seg_dist2(pp, b, c)), seg_dist2(pp, c, a))
        d2 = np.where(inside, h * h, d2)
        out[i] = d2.min()
    return out


@pytest.mark.parametrize("accel", STRUCTURES)
def test_distance_matches_a_reference(accel):
    rng = np.random.default_rng(3)
    v = rng.normal(size=(40, 3))
    f = rng.integers(0, 40, size=(60, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    q = rng.normal(size=(300, 3)) * 2
    r = RayScene((v, f), accel=accel).closest_points(q)
    assert np.allclose(r["distance"] ** 2, reference_d2(v, f, q), rtol=1e-12, atol=1e-15)
    # The point is on the face reported, at the barycentric weights reported.
    a, b, c = (v[f[r["prim_id"], k]] for k in range(3))
    u, w = r["u"][:, None], r["v"][:, None]
    assert np.allclose((1 - u - w) * a + u * b + w * c, r["point"], atol=1e-12)
    assert np.allclose(np.linalg.norm(r["point"] - q, axis=1), r["distance"], rtol=1e-12)


def test_every_structure_same_closest_points():
    v, f = box(3)
    q = np.random.default_rng(5).uniform(-2, 2, (500, 3))
    ref = RayScene((v, f), accel="none").closest_points(q)
    for accel in STRUCTURES:
        got = RayScene((v, f), accel=accel).closest_points(q)
        for k in ref:
            assert np.array_equal(ref[k], got[k], equal_nan=True), (accel, k)


def test_signed_distance_of_a_cube():
    v, f = box(2)
    rs = RayScene((v, f))
    q = np.array([[0.0, 0.0, 0.0], [0.5, 0.25, -0.75], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0],
                  [1.0, 0.5, 0.5]])
    assert np.allclose(rs.signed_distance(q), [-1.0, -0.25, 1.0, np.sqrt(2), 0.0])
    # Near an edge and a corner, outside and inside: the sign is right.
    near = np.array([[1 + 1e-9, 1 + 1e-9, 0.3], [1 - 1e-9, 1 - 1e-9, 0.3],
                     [1 + 1e-7, 1 + 1e-7, 1 + 1e-7], [1 - 1e-7, 1 - 1e-7, 1 - 1e-7]])
    assert (np.sign(rs.signed_distance(near)) == [1, -1, 1, -1]).all()


def test_spheres_planes_and_an_empty_scene():
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)),
                  objects=[Sphere((0, 0, 0), 1.0), Plane((0, -2, 0), (0, 1, 0))])
    r = RayScene(scene).closest_points([[0, 3.0, 0], [0, -1.8, 0], [0, 0, 0]])
    assert np.allclose(r["point"], [[0, 1, 0], [0, -2, 0], [1, 0, 0]])
    assert r["geometry_id"].tolist() == [0, 1, 0]
    assert np.isnan(r["u"]).all()
    empty = RayScene().closest_points([[0, 0, 0.0]])
    assert empty["distance"][0] == np.inf and empty["prim_id"][0] == -1


def test_bad_points():
    with pytest.raises(RaytraceError, match="points"):
        RayScene().distance([[0, 0]])
    with pytest.raises(RaytraceError, match=r"points\[1\]: NaN"):
        RayScene().distance([[0, 0, 0], [0, np.nan, 0]])
    with pytest.raises(RaytraceError, match=r"points\[0\]: a value beyond"):
        RayScene().contains([[0, 1e200, 0]])


def test_a_big_batch_answers_as_small_ones_do():
    # From _ORDER_MIN points on, the queries run in Morton order and are put
    # back: each point's answers must be those of a batch too small to sort.
    from raytrace.cast.rays import _ORDER_MIN
    v, f = box(3)
    rs = RayScene((v, f))
    rng = np.random.default_rng(9)
    q = rng.uniform(-2, 2, (_ORDER_MIN + 1000, 3))
    q[::7] = np.round(q[::7] * 4) / 4                          # on faces, edges and corners too
    chunks = [q[s:s + 10_000] for s in range(0, len(q), 10_000)]
    big = rs.closest_points(q)
    for k, a in big.items():
        assert np.array_equal(a, np.concatenate([rs.closest_points(c)[k] for c in chunks]),
                              equal_nan=True), k
    for name in ("distance", "contains", "signed_distance"):
        assert np.array_equal(getattr(rs, name)(q),
                              np.concatenate([getattr(rs, name)(c) for c in chunks])), name
    assert rs.contains(q).any() and not rs.contains(q).all()


@pytest.mark.parametrize("spread", [0.0, 1e-310, 1e-9, 1e90])
def test_a_big_batch_in_a_flat_or_tiny_or_huge_box(spread):
    # The Morton order's grid spans the points' box: one point repeated, a
    # subnormal extent, a huge one.
    from raytrace.cast.rays import _ORDER_MIN
    v, f = box(2)
    rs = RayScene((v, f))
    rng = np.random.default_rng(2)
    q = np.array([0.25, -0.5, 3.0]) + rng.uniform(0, 1, (_ORDER_MIN + 10, 3)) * [spread, 0, spread]
    got = rs.closest_points(q)
    small = rs.closest_points(q[:100])
    for k in got:
        assert np.array_equal(got[k][:100], small[k], equal_nan=True), k
    assert np.array_equal(rs.contains(q)[:100], rs.contains(q[:100]))
