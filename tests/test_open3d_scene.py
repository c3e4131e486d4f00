"""The Open3D drop-in (raytrace.cast.open3d_scene.RaycastingScene): Open3D's
methods, keys, dtypes and conventions, without Open3D installed; and, where
it is, the same answers as Open3D's own RaycastingScene."""
import numpy as np
import pytest

from raytrace import RaytraceError
from raytrace.cast.open3d_scene import INVALID_ID, RaycastingScene

# The unit cube [0, 1]^3, 12 faces wound outward (Open3D's create_box layout).
CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1],
                   [0, 1, 0], [1, 1, 0], [0, 1, 1], [1, 1, 1]], np.float32)
CUBE_F = np.array([[4, 7, 5], [4, 6, 7], [0, 2, 4], [2, 6, 4], [0, 1, 2], [1, 3, 2],
                   [1, 5, 7], [1, 7, 3], [2, 3, 7], [2, 7, 6], [0, 4, 1], [1, 4, 5]], np.uint32)
# Through the cube; from inside; a miss; from the bottom face up and down;
# a NaN origin; a zero direction.
RAYS = np.array([[0.5, 0.5, -1, 0, 0, 1], [0.5, 0.5, 0.5, 0, 0, 1], [10, 10, 10, 1, 0, 0],
                 [0.5, 0.5, 0, 0, 0, 1], [0.5, 0.5, 0, 0, 0, -1], [np.nan, 0, 0, 1, 0, 0],
                 [0, 0, 0.5, 0, 0, 0]], np.float32)


def plain(a):
    """A NumPy array of an answer (create_rays_pinhole answers with Open3D's
    tensors when Open3D has been imported, as Open3D does)."""
    return a.numpy() if hasattr(a, "numpy") else a


def cube_scene(**kw):
    scene = RaycastingScene(tensors=False, **kw)
    assert scene.add_triangles(CUBE_V, CUBE_F) == 0
    return scene


def test_cast_rays_keys_dtypes_and_misses():
    ans = cube_scene().cast_rays(RAYS)
    assert {k: (a.dtype, a.shape) for k, a in ans.items()} == {
        "t_hit": (np.float32, (7,)), "geometry_ids": (np.uint32, (7,)),
        "primitive_ids": (np.uint32, (7,)), "primitive_uvs": (np.float32, (7, 2)),
        "primitive_normals": (np.float32, (7, 3))}
    assert ans["t_hit"].tolist()[:5] == [1.0, 0.5, np.inf, 0.0, 0.0]   # t = 0 counts
    miss = [2, 5, 6]                                # no hit, NaN origin, zero direction
    assert np.isinf(ans["t_hit"][miss]).all()
    assert (ans["geometry_ids"][miss] == INVALID_ID).all()
    assert (ans["primitive_ids"][miss] == RaycastingScene.INVALID_ID).all()
    assert not ans["primitive_uvs"][miss].any() and not ans["primitive_normals"][miss].any()
    assert ans["primitive_normals"][0].tolist() == [0, 0, -1]
    assert ans["primitive_normals"][1].tolist() == [0, 0, 1]
    assert ans["geometry_ids"][[0, 1, 3, 4]].tolist() == [0, 0, 0, 0]
    # The uvs are barycentric weights of the face's second and third vertices.
    f = CUBE_F[ans["primitive_ids"][0]]
    u, v = ans["primitive_uvs"][0]
    hit = (1 - u - v) * CUBE_V[f[0]] + u * CUBE_V[f[1]] + v * CUBE_V[f[2]]
    assert np.allclose(hit, [0.5, 0.5, 0], atol=1e-7)


def test_occlusions_counts_and_lists():
    scene = cube_scene()
    occ = scene.test_occlusions(RAYS)
    assert occ.dtype == bool and occ.tolist() == [True, True, False, True, True, False, False]
    assert not scene.test_occlusions(RAYS, tfar=0.4)[[0, 1]].any()
    assert scene.test_occlusions(RAYS, tnear=1.5)[[0, 1]].tolist() == [True, False]
    counts = scene.count_intersections(RAYS)
    assert counts.dtype == np.int32 and counts.tolist() == [2, 1, 0, 2, 1, 0, 0]
    listed = scene.list_intersections(RAYS)
    assert {k: a.dtype for k, a in listed.items()} == {
        "ray_splits": np.uint32, "ray_ids": np.uint32, "geometry_ids": np.uint32,
        "primitive_ids": np.uint32, "primitive_uvs": np.float32, "t_hit": np.float32}
    assert listed["ray_splits"].tolist() == [0, 2, 3, 3, 5, 6, 6, 6]
    assert listed["ray_ids"].tolist() == [0, 0, 1, 3, 3, 4]
    assert listed["t_hit"].tolist() == [1.0, 2.0, 0.5, 0.0, 1.0, 0.0]
    assert listed["primitive_uvs"].shape == (6, 2)


def test_point_queries_in_any_shape():
    scene = cube_scene()
    q = np.array([[0.5, 0.5, 0.5], [-0.5, -0.5, -0.5], [0, 0, 0], [0.5, 0.5, 3]], np.float32)
    assert np.allclose(scene.compute_distance(q), [0.5, np.sqrt(0.75), 0, 2])
    assert np.allclose(scene.compute_signed_distance(q), [-0.5, np.sqrt(0.75), 0, 2])
    occ = scene.compute_occupancy(q)
    assert occ.dtype == np.float32 and occ.tolist()[:2] == [1.0, 0.0]
    assert scene.compute_occupancy(q, nsamples=5).tolist()[:2] == [1.0, 0.0]
    with pytest.raises(RaytraceError, match="votes"):
        scene.compute_occupancy(q, nsamples=4)
    c = scene.compute_closest_points(q)
    assert sorted(c) == ["geometry_ids", "points", "primitive_ids", "primitive_normals",
                         "primitive_uvs"]
    assert c["points"].dtype == np.float32 and c["primitive_ids"].dtype == np.uint32
    assert c["points"][3].tolist() == [0.5, 0.5, 1.0]
    assert c["primitive_normals"][3].tolist() == [0, 0, 1]
    grid = np.random.default_rng(1).uniform(-1, 2, (3, 4, 5, 3)).astype(np.float32)
    for name in ("compute_distance", "compute_signed_distance", "compute_occupancy"):
        assert getattr(scene, name)(grid).shape == (3, 4, 5)
    shaped = scene.compute_closest_points(grid)
    assert shaped["points"].shape == (3, 4, 5, 3) and shaped["primitive_uvs"].shape == (3, 4, 5, 2)
    assert np.array_equal(shaped["points"].reshape(-1, 3),
                          scene.compute_closest_points(grid.reshape(-1, 3))["points"])


def test_rays_in_an_image_shape_and_both_pinhole_forms():
    scene = cube_scene()
    rays = plain(RaycastingScene.create_rays_pinhole(fov_deg=60, center=[0.5, 0.5, 0.5],
                                                     eye=[0.5, 0.5, 4], up=[0, 1, 0],
                                                     width_px=8, height_px=6))
    assert rays.dtype == np.float32 and rays.shape == (6, 8, 6)
    ans = scene.cast_rays(rays)
    assert ans["t_hit"].shape == (6, 8) and ans["primitive_normals"].shape == (6, 8, 3)
    assert scene.count_intersections(rays).shape == (6, 8)
    assert np.isclose(ans["t_hit"][3, 4], 3.0, rtol=1e-3)      # looking at the z = 1 face
    f = 4 / np.tan(np.radians(30))
    k = [[f, 0, 4], [0, f, 3], [0, 0, 1]]
    ext = np.diag([-1.0, 1, -1, 1])                             # half a turn about y...
    ext[:3, 3] = -ext[:3, :3] @ [0.5, 0.5, 4]                   # ...at the same eye
    by_matrix = plain(RaycastingScene.create_rays_pinhole(k, ext, 8, 6))
    assert np.allclose(by_matrix, rays, atol=1e-6)
    with pytest.raises(RaytraceError, match="missing"):
        RaycastingScene.create_rays_pinhole(k, ext, width_px=8)


def test_meshes_as_objects_and_more_than_one():
    trimesh = pytest.importorskip("trimesh")
    scene = RaycastingScene(tensors=False)
    assert scene.add_triangles(trimesh.creation.box()) == 0
    assert scene.add_triangles(trimesh.creation.box().apply_translation([0, 0, 5])) == 1
    ans = scene.cast_rays(np.array([[0, 0, 10, 0, 0, -1], [0, 0, -10, 0, 0, 1]], np.float32))
    assert ans["geometry_ids"].tolist() == [1, 0]
    with pytest.raises(RaytraceError, match="add_triangles"):
        scene.add_triangles("cube.ply")
    with pytest.raises(RaytraceError, match="CPU"):
        RaycastingScene(device="CUDA:0")


def test_cast_rays_fields_are_rayscenes_in_open3ds_dtypes():
    """cast_rays' one-pass fields (kernels/hit_fields.py) are RayScene's, cast:
    the same bits, for hits, misses, a second mesh, normals whose squared
    length over- or underflows (unit_rows' scaled path) and rays in an image
    shape, over enough rays for more than one thread."""
    from raytrace import RayScene
    rng = np.random.default_rng(42)
    cube_v, cube_f = CUBE_V.astype(float), CUBE_F.astype(np.int64)
    soup_f = rng.integers(0, 60, (100, 3))
    soup_f = soup_f[(soup_f[:, 0] != soup_f[:, 1]) & (soup_f[:, 1] != soup_f[:, 2])
                    & (soup_f[:, 0] != soup_f[:, 2])]
    # (vertices, faces, the scale of the mesh): a corner of each at the origin.
    meshes = [(cube_v + [5, 0, 0], cube_f, 1.0), (cube_v * 1e-100, cube_f, 1e-100),
              (cube_v * -1e90, cube_f, 1e90), (rng.uniform(0, 1, (60, 3)) + [0, 5, 0], soup_f, 1.0)]
    ours = RaycastingScene(tensors=False)
    theirs = RayScene()
    n = 1500                # rays a mesh
    o, d = [], []
    for v, f, scale in meshes:
        ours.add_triangles(v, f)
        theirs.add_mesh(v, f)
        target = v.min(axis=0) + rng.uniform(0, 1, (n, 3)) * (v.max(axis=0) - v.min(axis=0))
        o.append(target + rng.normal(size=(n, 3)) * scale)
        d.append(target - o[-1])
    rays = np.concatenate([np.concatenate(o), np.concatenate(d)], axis=1)
    rays[::5, 3:] *= -1     # away from the target: mostly misses
    # float32: the meshes float32 can hold, in an image's shape.
    small = np.concatenate([rays[:n], rays[3 * n:]]).astype(np.float32).reshape(30, 100, 6)
    for r, geometries in ((rays, {0, 1, 2, 3}), (small, {0, 3})):
        ans = ours.cast_rays(r)
        h = theirs.cast_rays(r, t_min=-1)
        hit = h.hit
        assert 0.5 < hit.mean() < 0.9
        assert geometries <= set(np.unique(h.geometry_id[hit]))
        with np.errstate(over="ignore"):     # a t beyond float32 (the huge cube's): inf
            t32 = h.t.astype(np.float32)
        want = {"t_hit": t32,
                "geometry_ids": h.geometry_id.astype(np.uint32),
                "primitive_ids": h.prim_id.astype(np.uint32),
                "primitive_uvs": np.where(hit[..., None], np.stack([h.u, h.v], -1), 0),
                "primitive_normals": np.where(hit[..., None], h.normal, 0)}
        for k, a in want.items():
            a = a.astype(ans[k].dtype)
            assert ans[k].shape == a.shape, k
            assert np.array_equal(ans[k].view(np.uint8), a.view(np.uint8)), k


# With Open3D installed: the same answers as its own RaycastingScene, and
# its tensors in and out.

def test_same_answers_as_open3d():
    o3d = pytest.importorskip("open3d")
    mesh = o3d.t.geometry.TriangleMesh.create_sphere(0.8, 24)
    theirs = o3d.t.geometry.RaycastingScene()
    theirs.add_triangles(mesh)
    ours = RaycastingScene()
    assert ours.add_triangles(mesh) == 0
    rng = np.random.default_rng(7)
    o = rng.normal(size=(2000, 3)).astype(np.float32) * 2
    d = (rng.uniform(-0.5, 0.5, (2000, 3)) - o).astype(np.float32)
    rays = o3d.core.Tensor(np.concatenate([o, d], axis=1))
    a, b = ours.cast_rays(rays), theirs.cast_rays(rays)
    for k in b:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
    ids = b["primitive_ids"].numpy()
    assert np.array_equal(a["primitive_ids"].numpy(), ids)
    hit = ids != INVALID_ID
    assert np.allclose(a["t_hit"].numpy()[hit], b["t_hit"].numpy()[hit], rtol=1e-5)
    assert np.allclose(a["primitive_normals"].numpy(), b["primitive_normals"].numpy(), atol=1e-5)
    assert np.allclose(a["primitive_uvs"].numpy(), b["primitive_uvs"].numpy(), atol=1e-4)
    assert np.array_equal(ours.count_intersections(rays).numpy(),
                          theirs.count_intersections(rays).numpy())
    q = o3d.core.Tensor(rng.uniform(-1, 1, (500, 3)).astype(np.float32))
    assert np.array_equal(ours.compute_occupancy(q).numpy(), theirs.compute_occupancy(q).numpy())
    assert np.allclose(ours.compute_distance(q).numpy(), theirs.compute_distance(q).numpy(),
                       atol=1e-6)
    c, e = ours.compute_closest_points(q), theirs.compute_closest_points(q)
    assert np.allclose(c["points"].numpy(), e["points"].numpy(), atol=1e-6)
    # Where the closest point is on an edge the two may name either face;
    # where they name one face, they give it one normal, and ours is always
    # the normal of the face it names.
    same = c["primitive_ids"].numpy() == e["primitive_ids"].numpy()
    assert np.allclose(c["primitive_normals"].numpy()[same], e["primitive_normals"].numpy()[same],
                       atol=1e-6)
    v, f = mesh.vertex.positions.numpy(), mesh.triangle.indices.numpy()
    a, b, cc = (v[f[c["primitive_ids"].numpy(), k]].astype(float) for k in range(3))
    n = np.cross(b - a, cc - a)
    assert np.allclose(c["primitive_normals"].numpy(), n / np.linalg.norm(n, axis=1)[:, None],
                       atol=1e-6)
    # A legacy mesh, and pinhole rays as Open3D makes them.
    legacy = o3d.geometry.TriangleMesh.create_box()
    lg = RaycastingScene()
    lg.add_triangles(legacy)
    pin = dict(fov_deg=60.0, center=[0.5, 0.5, 0.5], eye=[2.0, 1.5, 3.0], up=[0.0, 1.0, 0.0],
               width_px=16, height_px=12)
    mine = RaycastingScene.create_rays_pinhole(**pin).numpy()
    real = o3d.t.geometry.RaycastingScene.create_rays_pinhole(**pin).numpy()
    assert np.allclose(mine, real, atol=1e-5)
    assert lg.count_intersections(o3d.core.Tensor(real)).numpy().shape == (12, 16)
