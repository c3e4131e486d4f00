"""The trimesh drop-in answers as trimesh's own ray module does."""
import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

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
