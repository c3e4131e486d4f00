"""RayScene options the trimesh and Open3D drop-ins need: a t_min that
counts hits at the origin, rays of any leading shape, any odd number of
votes, closest points with normals, one result type for every query."""
import numpy as np
import pytest

from raytrace import RayScene, RaytraceError
from raytrace.cast.results import ClosestPoints, RayHits
from raytrace.scene.model import Camera, Plane, Scene, Sphere
from tests.structures import STRUCTURES


def cube(half=1.0, subdivide=0):
    """A closed cube [-half, half]^3, each side a (2^k + 1)^2 grid of vertices."""
    import trimesh
    m = trimesh.creation.box(extents=[2 * half] * 3)
    for _ in range(subdivide):
        m = m.subdivide()
    return m


@pytest.mark.parametrize("accel", STRUCTURES)
def test_a_negative_t_min_counts_the_face_a_ray_starts_on(accel):
    m = cube(subdivide=1)
    rs = RayScene(m, accel=accel)
    # From the top face's centre (a vertex of 8 faces once subdivided), from
    # inside a face, and from the top face pointing away from the cube.
    o = np.array([[0.0, 0.0, 1.0], [0.3, 0.1, 1.0], [0.3, 0.1, 1.0], [0.3, 0.1, 3.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    assert rs.count_intersections(o, d).tolist() == [1, 1, 0, 2]
    assert rs.count_intersections(o, d, t_min=-1).tolist() == [2, 2, 1, 2]
    h = rs.cast_rays(o, d, t_min=-1)
    assert h.t.tolist() == [0.0, 0.0, 0.0, 2.0]
    assert np.array_equal(h.point[:3, 2], [1.0, 1.0, 1.0])
    assert rs.occluded(o, d, t_min=-1).all() and not rs.occluded(o, d)[2]
    listed = rs.list_intersections(o, d, t_min=-1e-300)
    assert np.diff(listed.ray_splits).tolist() == [2, 2, 1, 2]
    assert listed.t[:2].tolist() == [0.0, 2.0]
    # The same rays with t_min = 0 do not see t = 0, whatever the structure.
    assert np.isinf(rs.cast_rays(o[2:3], d[2:3]).t[0])
    # Nothing behind the origin ever counts, however negative t_min is.
    assert rs.count_intersections(o, d, t_min=-np.inf).tolist() == [2, 2, 1, 2]
    per_ray = rs.count_intersections(o, d, t_min=np.array([-1.0, 0.0, -1.0, 0.0]))
    assert per_ray.tolist() == [2, 1, 1, 2]


def test_a_negative_t_min_on_spheres_and_planes():
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)),
                  objects=[Sphere((0, 0, 0), 1.0), Plane((0, -2, 0), (0, 1, 0))])
    rs = RayScene(scene)
    o = np.array([[0.0, 0.0, 1.0], [0.0, -2.0, 0.0], [0.0, 0.0, 1.0]])
    d = np.array([[0.0, 0.0, -1.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    h = rs.cast_rays(o, d, t_min=-1)
    assert h.t.tolist() == [0.0, 0.0, 0.0]
    assert h.geometry_id.tolist() == [0, 1, 0]
    assert h.t.tolist() != rs.cast_rays(o, d).t.tolist()
    # Out of the sphere's top, upward: only the origin (the far root is behind).
    assert rs.count_intersections(o[2:], d[2:], t_min=-1).tolist() == [1]


def test_bad_t_min_still_named():
    rs = RayScene(cube())
    with pytest.raises(RaytraceError, match=r"t_min\[0\]"):
        rs.cast_rays([0, 0, 5.0], [0, 0, -1.0], t_min=2.0, t_max=1.0)
    with pytest.raises(RaytraceError, match=r"t_min\[0\]"):
        rs.cast_rays([0, 0, 5.0], [0, 0, -1.0], t_min=np.nan)


def test_rays_of_any_leading_shape_answer_in_that_shape():
    rs = RayScene(cube())
    rng = np.random.default_rng(4)
    o = rng.uniform(-3, 3, (4, 5, 3))
    d = rng.uniform(-0.5, 0.5, (4, 5, 3)) - o
    flat = rs.cast_rays(o.reshape(-1, 3), d.reshape(-1, 3))
    for h in (rs.cast_rays(o, d), rs.cast_rays(np.concatenate([o, d], axis=-1))):
        assert isinstance(h, RayHits)
        assert h.t.shape == (4, 5) and h.normal.shape == (4, 5, 3) and h.hit.shape == (4, 5)
        for k in RayHits.FIELDS:
            assert np.array_equal(h[k].reshape(flat[k].shape), flat[k], equal_nan=True), k
    rays = np.concatenate([o, d], axis=-1)
    assert rs.occluded(rays).shape == (4, 5)
    assert np.array_equal(rs.count_intersections(rays).ravel(),
                          rs.count_intersections(o.reshape(-1, 3), d.reshape(-1, 3)))
    listed = rs.list_intersections(rays)
    assert len(listed.ray_splits) == 21
    # One origin for every direction of an image, and per-ray bounds in its shape.
    h = rs.cast_rays([0, 0, 5.0], d, t_max=np.full((4, 5), 100.0))
    assert h.t.shape == (4, 5)
    # float32 rays are read as they are, once converted.
    f32 = rs.cast_rays(rays.astype(np.float32))
    assert np.array_equal(f32.t, rs.cast_rays(rays.astype(np.float32).astype(float)).t)


def test_bad_ray_shapes():
    rs = RayScene(cube())
    with pytest.raises(RaytraceError, match=r"rays: expected shape \(n, 6\)"):
        rs.cast_rays(np.zeros((4, 5)))
    with pytest.raises(RaytraceError, match="differ in shape"):
        rs.cast_rays(np.zeros((4, 5, 3)), np.ones((5, 4, 3)))
    with pytest.raises(RaytraceError, match="t_max: expected"):
        rs.cast_rays(np.zeros((4, 5, 3)) + 5, np.ones((4, 5, 3)), t_max=np.ones((5, 4)))


@pytest.mark.parametrize("votes", [1, 3, 5, 7, 9])
def test_any_odd_number_of_votes(votes):
    rs = RayScene(cube(subdivide=1))
    q = np.random.default_rng(votes).uniform(-1.5, 1.5, (3000, 3))
    clear = np.abs(np.abs(q).max(axis=1) - 1.0) > 1e-9
    inside = (np.abs(q) < 1.0).all(axis=1)
    assert np.array_equal(rs.contains(q, votes=votes)[clear], inside[clear])
    d = rs.signed_distance(q, votes=votes)
    assert np.array_equal((d < 0)[clear], inside[clear])


def test_votes_decide_by_majority_past_a_hole():
    # A cube missing one top face: along +z a point under the hole counts
    # 0 crossings; the other directions outvote it.
    m = cube(subdivide=1)
    top = np.flatnonzero(m.triangles_center[:, 2] > 0.99)[0]
    holed = RayScene((m.vertices, np.delete(m.faces, top, axis=0)))
    p = m.triangles_center[top] - [0, 0, 0.3]
    # One vote goes out through the hole (the top is nearest); more outvote it.
    assert [holed.contains([p], votes=k)[0] for k in (1, 3, 5, 7, 9)] == [False] + [True] * 4
    for votes in (2, 0, -1, 1.0, True):
        with pytest.raises(RaytraceError, match="votes: must be an odd positive integer"):
            holed.contains([p], votes=votes)


def test_closest_points_answer_with_normals_in_one_result_type():
    m = cube()
    rs = RayScene(m)
    q = np.array([[0.2, 0.1, 3.0], [5.0, 0.3, 0.2], [0.1, -4.0, 0.0]])
    c = rs.closest_points(q)
    assert isinstance(c, ClosestPoints)
    assert np.array_equal(c.normal, m.face_normals[c.prim_id])
    assert np.array_equal(c["normal"], c.normal) and list(c.keys()) == list(c)
    assert dict(c.items())["distance"].tolist() == [2.0, 4.0, 3.0]
    assert c.object_id.tolist() == [0, 0, 0]
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)),
                  objects=[Sphere((0, 0, 0), 1.0), Plane((0, -2, 0), (0, 1, 0))])
    s = RayScene(scene).closest_points([[0, 3.0, 0], [0, -1.8, 0], [1.5, 0, 0]])
    assert np.allclose(s.normal, [[0, 1, 0], [0, 1, 0], [1, 0, 0]])
    with pytest.raises(KeyError, match="fields"):
        c["nope"]


def test_float32_rays_answer_as_their_float64_values_and_kept_hits_stay_theirs():
    """float32 rays (and Open3D's float32 rows of 6) are copied into a
    buffer the thread keeps for its next call (cast/rays.py): the answers
    are those of the same values in float64, and a RayHits read after a
    later call still describes its own rays (it keeps the rays as given)."""
    scene = Scene("f32", Camera((0, 0, 5), (0, 0, 0)),
                  [Sphere((0.0, 0.0, 0.0), 1.0), Plane((0, -2, 0), (0, 1, 0))])
    rs = RayScene(scene)
    rng = np.random.default_rng(4)
    o32 = np.tile(np.float32([0.1, 0.2, 5.0]), (5000, 1))
    d32 = (rng.standard_normal((5000, 3)) * [0.3, 0.3, 0.1] - [0, 0, 1]).astype(np.float32)
    first = rs.cast_rays(o32, d32)
    same = rs.cast_rays(o32.astype(np.float64), d32.astype(np.float64))
    rows = rs.cast_rays(np.hstack([o32, d32]))
    for h in (same, rows):
        assert np.array_equal(first.t, h.t) and np.array_equal(first.prim_id, h.prim_id)
    assert first.hit.sum() > 1000 and (~first.hit).sum() > 100
    # Another float32 call of the same size overwrites the thread's buffers.
    rs.cast_rays(-o32, -d32)
    assert rs.occluded(o32[::-1].copy(), d32[::-1].copy()).shape == (5000,)
    assert np.array_equal(first.point, same.point, equal_nan=True)
    assert np.array_equal(first.normal, same.normal, equal_nan=True)
