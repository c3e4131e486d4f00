"""The trimesh drop-in answers as trimesh's own ray module does."""
import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

from raytrace import RaytraceError  # noqa: E402
from raytrace.cast.trimesh_ray import RayMeshIntersector  # noqa: E402


def rays(n=400, seed=0):
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3)) * 3
    target = rng.uniform(-0.8, 0.8, (n, 3))
    return o, target - o


@pytest.fixture(scope="module")
def mesh():
    return trimesh.creation.icosphere(subdivisions=2)


def test_same_first_hits_and_any_hits_as_trimesh(mesh):
    o, d = rays()
    ours = RayMeshIntersector(mesh)
    theirs = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    assert np.array_equal(ours.intersects_first(o, d), theirs.intersects_first(o, d))
    assert np.array_equal(ours.intersects_any(o, d), theirs.intersects_any(o, d))


def test_same_multiple_hits_as_trimesh(mesh):
    o, d = rays(seed=1)
    ours = RayMeshIntersector(mesh)
    theirs = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    tri, ray, loc = ours.intersects_id(o, d, return_locations=True, multiple_hits=True)
    ttri, tray, tloc = theirs.intersects_id(o, d, return_locations=True, multiple_hits=True)
    assert sorted(zip(ray.tolist(), tri.tolist())) == sorted(zip(tray.tolist(), ttri.tolist()))
    order, torder = np.lexsort((tri, ray)), np.lexsort((ttri, tray))
    assert np.allclose(loc[order], tloc[torder], atol=1e-9)
    loc2, ray2, tri2 = ours.intersects_location(o, d)
    assert np.array_equal(ray2, ray) and np.array_equal(tri2, tri) and np.array_equal(loc2, loc)
    first_tri, first_ray = ours.intersects_id(o, d, multiple_hits=False)
    assert np.array_equal(first_ray, np.flatnonzero(ours.intersects_any(o, d)))
    assert np.array_equal(first_tri, ours.intersects_first(o, d)[first_ray])


def test_contains_points_and_the_one_line_switch(mesh):
    q = np.random.default_rng(2).uniform(-1.2, 1.2, (2000, 3))
    r = np.linalg.norm(q, axis=1)
    clear = np.abs(r - 0.99) > 0.02
    mesh = mesh.copy()
    mesh.ray = RayMeshIntersector(mesh)
    assert np.array_equal(mesh.ray.contains_points(q)[clear], (r < 0.99)[clear])
    assert np.array_equal(mesh.contains(q), mesh.ray.contains_points(q))


@pytest.fixture
def installed():
    import raytrace.cast.trimesh_ray as tr
    tr.install()
    try:
        yield tr
    finally:
        tr.uninstall()


def test_install_makes_every_new_mesh_use_raytrace_and_uninstall_undoes_it(installed):
    from raytrace.cast.trimesh_ray import EmbreeRayMeshIntersector
    ours = (RayMeshIntersector, EmbreeRayMeshIntersector)
    assert isinstance(trimesh.creation.box().ray, ours)
    assert isinstance(trimesh.creation.box(use_embree=False).ray, RayMeshIntersector)
    assert trimesh.ray.ray_triangle.RayMeshIntersector is RayMeshIntersector
    installed.uninstall()
    assert not isinstance(trimesh.creation.box().ray, ours)
    assert not isinstance(trimesh.creation.box(use_embree=False).ray, ours)


def test_primitives_and_bounding_boxes_are_read_when_asked(installed):
    # trimesh makes mesh.ray before a primitive has its data.
    down = np.array([[0.0, 0.0, -1.0]])
    box = trimesh.primitives.Box(extents=[1, 1, 1])
    assert box.ray.intersects_first([[0, 0, 5.0]], down).tolist() != [-1]
    sphere = trimesh.primitives.Sphere(radius=2.0)
    assert sphere.contains([[0, 0, 1.5], [0, 0, 2.5]]).tolist() == [True, False]
    assert trimesh.primitives.Cylinder(radius=1, height=2).ray.intersects_any([[0, 0, 5.0]], down)
    assert box.bounding_box.ray.intersects_any([[0, 0, 5.0]], down)[0]


def test_a_2d_mesh_fails_only_when_asked_a_question():
    flat = trimesh.Trimesh(vertices=[[0, 0], [1, 0], [0, 1]], faces=[[0, 1, 2]], process=False)
    ray = RayMeshIntersector(flat)             # reads nothing yet
    with pytest.raises(RaytraceError, match="vertices"):
        ray.intersects_any([[0, 0, 1.0]], [[0, 0, -1.0]])


def test_answers_follow_the_mesh_when_it_moves():
    box = trimesh.creation.box()
    box.ray = RayMeshIntersector(box)
    o, d = [[10.0, 0, -5]], [[0, 0, 1.0]]
    assert not box.ray.intersects_any(o, d)[0]
    box.apply_translation([10, 0, 0])
    assert box.ray.intersects_any(o, d)[0]
    loc, _, _ = box.ray.intersects_location(o, d)
    assert np.allclose(loc[:, 0], 10.0)
    prim = trimesh.primitives.Box(extents=[1, 1, 1])
    prim.ray = RayMeshIntersector(prim)
    assert prim.ray.intersects_first([[0, 0, -5.0]], d)[0] >= 0
    prim.apply_translation([10, 0, 0])
    assert prim.ray.intersects_first([[0, 0, -5.0]], d).tolist() == [-1]
    assert prim.ray.intersects_first(o, d)[0] >= 0


@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e4, 1e8])
def test_a_ray_from_a_face_hits_it_and_each_crossing_once(scale):
    from raytrace.cast.trimesh_ray import EmbreeRayMeshIntersector
    mesh = trimesh.creation.box().subdivide().subdivide()
    mesh.apply_scale(scale)
    for cls in (RayMeshIntersector, EmbreeRayMeshIntersector):
        mesh.ray = cls(mesh, scale_to_box=False)
        # From the top's centre, a vertex of 8 faces, down through the bottom's.
        o, d = [[0.0, 0.0, scale / 2]], [[0.0, 0.0, -1.0]]
        tri, ray = mesh.ray.intersects_id(o, d, multiple_hits=True)
        assert len(tri) == 2 and ray.tolist() == [0, 0]
        assert mesh.triangles_center[tri[0], 2] == scale / 2         # the face it starts on
        # The closest hit is one of the 8 faces there (the smallest id; the
        # crossing goes to the face that owns the vertex, maybe another).
        first = mesh.ray.intersects_first(o, d)[0]
        assert first >= 0 and mesh.triangles_center[first, 2] == scale / 2
        assert mesh.ray.intersects_any([[0.1 * scale, 0.0, scale / 2]], [[0, 0, 1.0]])[0]


def test_return_types_orders_and_max_hits():
    from raytrace.cast.trimesh_ray import EmbreeRayMeshIntersector
    mesh = trimesh.creation.box()
    o = np.array([[0.1, 0.2, -5], [9, 9, -5], [0.3, -0.2, -5], [0.2, 0.1, 5]])
    d = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0]])
    by_ray = RayMeshIntersector(mesh)
    tri, ray, loc = by_ray.intersects_id(o, d, return_locations=True)
    assert tri.dtype == ray.dtype == np.int64 and loc.dtype == np.float64 and loc.shape == (6, 3)
    assert ray.tolist() == [0, 0, 2, 2, 3, 3]                    # ray by ray, nearest first
    assert loc[:, 2].tolist() == [-0.5, 0.5, -0.5, 0.5, 0.5, -0.5]
    by_rank = EmbreeRayMeshIntersector(mesh)
    tri2, ray2, loc2 = by_rank.intersects_id(o, d, return_locations=True)
    assert ray2.tolist() == [0, 2, 3, 0, 2, 3]                   # Embree's passes: firsts, seconds
    assert loc2[:, 2].tolist() == [-0.5, -0.5, 0.5, 0.5, 0.5, -0.5]
    assert sorted(zip(ray2.tolist(), tri2.tolist())) == sorted(zip(ray.tolist(), tri.tolist()))
    assert by_ray.intersects_id(o, d, max_hits=1)[1].tolist() == [0, 2, 3]
    first = by_ray.intersects_first(o, d)
    assert first.dtype == np.int64 and first[1] == -1
    assert by_ray.intersects_any(o, d).dtype == bool
    # No hits: empty arrays of the same kinds.
    none = by_ray.intersects_location(o[1:2], d[1:2])
    assert [a.shape for a in none] == [(0, 3), (0,), (0,)]
    assert none[1].dtype == np.int64
    # A zero or NaN direction misses, as in trimesh's engines.
    assert by_ray.intersects_any([[0, 0, -5.0], [np.nan, 0, -5]], [[0, 0, 0.0], [0, 0, 1]]).tolist() \
        == [False, False]


def test_copies_and_pickles_rebuild_their_own_scene():
    import copy
    import pickle
    mesh = trimesh.creation.box()
    mesh.ray = RayMeshIntersector(mesh, accel="grid")
    assert mesh.ray.intersects_any([[0, 0, -5.0]], [[0, 0, 1.0]])[0]
    twin = pickle.loads(pickle.dumps(mesh.ray))
    assert twin._scene is None and twin.accel == "grid"
    assert twin.intersects_any([[0, 0, -5.0]], [[0, 0, 1.0]])[0]
    assert copy.deepcopy(mesh.ray).mesh is mesh
    with pytest.raises(RaytraceError, match="acceleration structure"):
        RayMeshIntersector(mesh, accel="octree")
