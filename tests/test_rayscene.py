"""RayScene: built once, queried many times; geometry ids, t_min, normals
and hit points, the same answers from every structure."""
import numpy as np
import pytest

import raytrace
from raytrace import RayScene, RaytraceError
from raytrace.scene.model import Camera, Material, Plane, Scene, Sphere
from tests.structures import STRUCTURES

# Two unit squares in z = 0 and z = -2, faces wound so their normals point +z.
SQUARE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])
DOWN = [0.0, 0.0, -1.0]


def two_squares(accel="bvh"):
    scene = RayScene(accel=accel)
    assert scene.add_mesh(SQUARE_V, SQUARE_F) == 0
    assert scene.add_mesh((SQUARE_V - [0, 0, 2], SQUARE_F)) == 1
    return scene


@pytest.mark.parametrize("accel", STRUCTURES)
def test_geometry_ids_faces_normals_and_points(accel):
    s = two_squares(accel)
    o = [[0.75, 0.25, 1.0], [0.25, 0.75, 1.0], [5, 5, 1.0]]
    h = s.cast_rays(o, DOWN)
    assert h.geometry_id.tolist() == [0, 0, -1]
    assert h.prim_id.tolist() == [0, 1, -1]
    assert h.t[:2].tolist() == [1.0, 1.0] and h.t[2] == np.inf
    assert np.array_equal(h.normal[:2], [[0, 0, 1.0], [0, 0, 1.0]])
    assert np.allclose(h.point[:2], [[0.75, 0.25, 0], [0.25, 0.75, 0]], atol=1e-15, rtol=0)
    assert np.isnan(h.normal[2]).all() and np.isnan(h.point[2]).all()


def test_a_scene_of_shaded_meshes_is_built_without_what_only_shading_reads():
    """Ray queries never shade: the meshes' vertex normals, colours and
    texture coordinates are not flattened (they cost half of flattening),
    and the normal a hit reports is still the face's own."""
    from raytrace.scene.model import Mesh
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    tilted = np.array([[0.6, 0, 0.8]] * 3)
    mesh = Mesh(v, np.array([[0, 1, 2]]), normals=tilted, colors=np.full((3, 3), 0.5))
    s = RayScene(Scene("s", Camera((0, 0, 5), (0, 0, 0)), [mesh]))
    h = s.cast_rays([[0.2, 0.2, 1.0]], DOWN)
    geo = s._built().geo
    assert geo.vtx_normal.shape[0] == 0 and geo.tri_normal.shape[0] == 0
    assert geo.vtx_color.shape[0] == 0 and geo.tri_vertex.shape[0] == 0
    assert h.normal.tolist() == [[0.0, 0.0, 1.0]]


@pytest.mark.parametrize("accel", STRUCTURES)
def test_t_min_skips_nearer_hits(accel):
    s = two_squares(accel)
    o = [[0.5, 0.3, 1.0]] * 4
    h = s.cast_rays(o, DOWN, t_min=[0.0, 1.0, 2.5, 3.0], t_max=[np.inf, np.inf, np.inf, 3.5])
    # Both ends are exclusive: at t_min = 1.0 the first square (t = 1) no
    # longer counts, and at t_min = 3.0 the second (t = 3) neither.
    assert h.geometry_id.tolist() == [0, 1, 1, -1]
    assert h.t.tolist() == [1.0, 3.0, 3.0, np.inf]
    occ = s.occluded(o, DOWN, t_min=[0.0, 1.0, 3.0, 0.5], t_max=[1.5, 3.5, 10.0, 1.0])
    assert occ.tolist() == [True, True, False, False]


@pytest.mark.parametrize("accel", STRUCTURES)
def test_no_rays_and_no_points_give_empty_answers(accel):
    s = two_squares(accel)
    none = np.zeros((0, 3))
    assert s.cast_rays(none, none)["t"].shape == (0,)
    assert s.occluded(none, none).shape == (0,)
    assert s.count_intersections(none, none).shape == (0,)
    hits = s.list_intersections(none, none)
    assert list(hits.ray_splits) == [0] and len(hits.t) == 0
    assert s.contains(none).shape == (0,) and s.distance(none).shape == (0,)


def test_sphere_and_plane_normals_and_points():
    m = Material()
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[
        Plane((0, -1, 0), (0, 2, 0), m), Sphere((3, 0, 0), 1.0, m)])
    h = RayScene(scene).cast_rays([[3.0, 0.0, 5.0], [-4.0, 0.0, 0.0]], [[0, 0, -1.0], [0, -1.0, 0]])
    assert h.geometry_id.tolist() == [1, 0]
    assert np.allclose(h.normal, [[0, 0, 1.0], [0, 1.0, 0]])
    assert np.allclose(h.point, [[3, 0, 1.0], [-4, -1.0, 0]])
    assert np.isnan(h.u).all()    # only triangles have barycentrics


def test_inside_a_sphere_t_min_finds_the_far_side():
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[Sphere((0, 0, 0), 1.0)])
    rs = RayScene(scene)
    h = rs.cast_rays([[0.0, 0.0, 2.0]], DOWN, t_min=1.5)    # past the near side at t = 1
    assert h.t[0] == pytest.approx(3.0) and np.allclose(h.normal[0], [0, 0, -1.0])


def test_built_once_and_rebuilt_after_add_mesh():
    s = two_squares()
    s.cast_rays([[0.5, 0.5, 1.0]], DOWN)
    built = s._prepared
    s.occluded([[0.5, 0.5, 1.0]], DOWN)
    assert s._prepared is built
    s.add_mesh(SQUARE_V + [0, 0, 0.5], SQUARE_F)
    assert s.cast_rays([[0.5, 0.5, 1.0]], DOWN).geometry_id.tolist() == [2]


@pytest.mark.parametrize("seed", range(3))
def test_every_structure_same_answers_with_random_bounds(seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(90, 3))
    f = rng.integers(0, 90, size=(60, 3))
    n = 3000     # three chunks of rays (kernels/cast.py): both threads take some
    o = rng.normal(size=(n, 3)) * 3
    d = rng.normal(size=(n, 3))
    t_min = rng.uniform(0, 2, n)
    t_max = t_min + rng.uniform(0.01, 5, n)
    ref = None
    for accel in STRUCTURES:
        s = RayScene((v, f), accel=accel)
        h = s.cast_rays(o, d, t_min=t_min, t_max=t_max)
        got = (h.t, h.prim_id, h.u, h.v, s.occluded(o, d, t_min=t_min, t_max=t_max))
        hit = h.hit
        assert ((h.t[hit] > t_min[hit]) & (h.t[hit] < t_max[hit])).all()
        if ref is None:
            ref = got
        for a, b in zip(ref, got):
            assert np.array_equal(a, b, equal_nan=True), accel
        assert np.array_equal(got[4][hit], np.ones(hit.sum(), bool))



@pytest.mark.parametrize("accel", ["bvh", "grid"])
def test_one_block_in_the_calling_thread_answers_as_the_threads_do(monkeypatch, accel):
    """A query of one block runs without Numba's threads (kernels/cast.py):
    every query, forced into one block and into three, gives the same
    answers and the same counters."""
    from raytrace.cast import rays, rayscene
    rng = np.random.default_rng(5)
    v, f = rng.normal(size=(90, 3)), rng.integers(0, 90, size=(60, 3))
    n = 2500     # three chunks of rays; 40 of points (accel/bvh/points.py)
    o, d, q = rng.normal(size=(n, 3)) * 3, rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    runs = {}
    for blocks in (1, 3):
        for module in (rays, rayscene):
            monkeypatch.setattr(module, "_blocks", lambda n, chunk=None, k=blocks: k)
        s = RayScene((v, f), accel=accel)
        h = s.cast_rays(o, d)
        hits = s.list_intersections(o, d)
        runs[blocks] = ([h[k] for k in h.FIELDS] + [s.occluded(o, d), s.count_intersections(o, d)]
                        + [hits[k] for k in ("ray_splits", "t", "prim_id", "u", "v")]
                        + list(s.closest_points(q).values()), h.stats, hits.stats)
    one, three = runs[1], runs[3]
    assert len(one[0]) == len(three[0])
    for a, b in zip(one[0], three[0]):
        assert np.array_equal(a, b, equal_nan=True)
    assert one[1:] == three[1:] and one[1]["prim_tests"] > 0

def test_calls_of_one_ray_on_scenes_of_two_structures_keep_their_own_kernels():
    """A call of one ray runs its kernel's compiled entry point, kept per
    prepared scene (kernels/entry.py entry_of).  The grid's and the
    BVH's layouts are different types, so an entry kept for one scene and
    used by the other would read its arrays wrongly: calls alternating
    between the two answer ray by ray as each scene's batch call does, and
    a rebuilt scene keeps new entries."""
    rng = np.random.default_rng(11)
    v, f = rng.normal(size=(60, 3)), rng.integers(0, 60, size=(40, 3))
    o = rng.normal(size=(30, 3)) * 3
    d = rng.normal(size=(30, 3)) * 0.5 - o        # towards the soup: most hit, some miss
    scenes = [RayScene((v, f), accel=a) for a in ("bvh", "grid")]
    batch = [(s.cast_rays(o, d), s.occluded(o, d), s.count_intersections(o, d)) for s in scenes]
    for i in range(len(o)):
        for s, (h, blocked, counts) in zip(scenes, batch):
            one = s.cast_rays(o[i], d[i])
            assert (one["t"][0], one["prim_id"][0]) == (h["t"][i], h["prim_id"][i])
            assert s.occluded(o[i], d[i])[0] == blocked[i]
            assert s.count_intersections(o[i], d[i])[0] == counts[i]
    assert 0 < (batch[0][0]["prim_id"] >= 0).sum() < len(o) and batch[0][1].any()
    assert (batch[0][2] > 1).any()
    first = scenes[0]._built()
    assert len(first.entries) == 3           # closest, any hit and counting
    scenes[0].add_mesh(SQUARE_V + [100, 0, 0], SQUARE_F)     # away from the soup
    assert scenes[0].cast_rays([100.5, 0.5, 1.0], DOWN)["geometry_id"][0] == 1
    assert scenes[0]._built() is not first and len(scenes[0]._built().entries) == 1


def test_calls_of_many_rays_alternated_between_structures_keep_their_own_kernels():
    """Calls of several chunks of rays, on two threads, run their kernels'
    compiled entry points too (kernels/cast.py run_blocks), kept per
    prepared scene, and so do point queries: alternating between a BVH and
    a grid scene, and between float64 rays and float32 ones, every call
    answers as that scene's first did, and the BVH keeps its packet
    kernels' entries, the grid its one-ray kernels'."""
    from raytrace.kernels import cast
    rng = np.random.default_rng(12)
    v, f = rng.normal(size=(60, 3)), rng.integers(0, 60, size=(40, 3))
    o32 = (rng.normal(size=(3000, 3)) * 3).astype(np.float32)
    d32 = (rng.normal(size=(3000, 3)) * 0.5 - o32).astype(np.float32)
    o, d = o32.astype(np.float64), d32.astype(np.float64)
    scenes = [RayScene((v, f), accel=a) for a in ("bvh", "grid")]

    def answers(s, o, d):
        h = s.cast_rays(o, d)
        listed = s.list_intersections(o, d)
        return [h["t"], h["prim_id"], s.occluded(o, d), s.count_intersections(o, d),
                listed["ray_splits"], listed["t"], s.distance(o), s.distance(d[:7])]
    first = [answers(s, o, d) for s in scenes]
    for rays in ((o32, d32), (o, d), (o32, d32)):
        for s, want in zip(scenes, first):
            for got, expected in zip(answers(s, *rays), want):
                assert np.array_equal(got, expected)
    assert 0 < (first[0][1] >= 0).sum() < len(o) and (first[0][3] > 1).any()
    bvh, grid = (s._built().entries for s in scenes)
    assert {cast._closest_block, cast._occluded_block} <= set(bvh)
    assert cast._closest_single in grid and cast._closest_block not in grid


def test_same_answers_as_the_one_call_functions():
    rng = np.random.default_rng(4)
    v, f = rng.normal(size=(30, 3)), rng.integers(0, 30, size=(20, 3))
    o, d = rng.normal(size=(200, 3)) * 2, rng.normal(size=(200, 3))
    a = RayScene((v, f)).cast_rays(o, d)
    b = raytrace.cast_rays((v, f), o, d)
    for name in a.FIELDS:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


@pytest.mark.parametrize("kw, message", [
    (dict(t_min=2.0, t_max=1.0), r"t_min\[0\]: .* below t_max"),
    (dict(t_min=np.nan), r"t_min\[0\]"),
    (dict(t_min=[0.0, 0.0]), r"t_min: expected a number or shape \(1,\)"),
    (dict(t_max=0.0), r"t_max\[0\]: must be positive"),
])
def test_bad_bounds_name_the_argument(kw, message):
    with pytest.raises(RaytraceError, match=message):
        two_squares().cast_rays([[0.5, 0.5, 1.0]], DOWN, **kw)


@pytest.mark.parametrize("accel", STRUCTURES)
@pytest.mark.parametrize("query", ["cast_rays", "occluded", "count_intersections",
                                   "list_intersections"])
@pytest.mark.parametrize("row, change, message", [
    (700, ("o", [np.nan, 0, 0]), r"origins\[700\]: NaN or infinite value \(1 such rows\)"),
    (3, ("d", [0.0, -0.0, 0.0]), r"directions\[3\]: zero vector"),
    (2999, ("d", [0, 0, 2e100]), r"directions\[2999\]: a value beyond 1e\+100"),
    (1100, ("t_min", 3.0), r"t_min\[1100\]: .* below t_max"),
])
def test_a_bad_ray_among_good_ones_is_named_by_every_query(accel, query, row, change, message):
    # The kernels check each ray as they read it (kernels/cast.py): a bad
    # ray anywhere in a batch, in any thread's chunk (CHUNK rays: these
    # 3,000 make three), is found and named.
    n = 3000
    rng = np.random.default_rng(row)
    o = np.column_stack([rng.uniform(0, 2, n), rng.uniform(0, 1, n), np.ones(n)])
    d = np.tile(DOWN, (n, 1))
    t_min, t_max = np.zeros(n), np.full(n, 2.0)
    arrays = {"o": o, "d": d, "t_min": t_min}
    arrays[change[0]][row] = change[1]
    scene = two_squares(accel)
    with pytest.raises(RaytraceError, match=message):
        getattr(scene, query)(o, d, t_min=t_min, t_max=t_max)
    arrays[change[0]][row] = {"o": o[row - 1], "d": DOWN, "t_min": 0.0}[change[0]]
    getattr(scene, query)(o, d, t_min=t_min, t_max=t_max)     # fixed, it runs


def test_bad_meshes_and_structures():
    with pytest.raises(RaytraceError, match=r"mesh 0: face 0 indexes a vertex out of range"):
        RayScene().add_mesh(SQUARE_V, [[0, 1, 9]])
    with pytest.raises(RaytraceError, match="target must be"):
        RayScene().add_mesh("square.obj")
    with pytest.raises(RaytraceError, match="unknown acceleration structure"):
        RayScene(accel="kd")


def test_pinhole_rays_follow_the_camera():
    rays = raytrace.create_rays_pinhole(90, center=[0, 0, 0], eye=[0, 0, 5], up=[0, 1, 0],
                                        width=4, height=2)
    assert rays.shape == (2, 4, 6)
    assert np.array_equal(rays[..., :3], np.broadcast_to([0, 0, 5.0], (2, 4, 3)))
    # 90 degrees across 4 pixels: focal length 2, pixel centres at x - 2 = -1.5 .. 1.5;
    # unit depth along -z.  Open3D's frame: camera x along up x forward (world -x
    # here), camera y along up, so row 0 looks down: half a turn from a photograph.
    d = rays[..., 3:]
    assert np.allclose(d[..., 2], -1.0)
    assert np.allclose(d[0, :, 0], [0.75, 0.25, -0.25, -0.75])
    assert np.allclose(d[:, 0, 1], [-0.25, 0.25])
    hits = RayScene((SQUARE_V - [0.5, 0.5, 0], SQUARE_F)).cast_rays(
        rays[..., :3].reshape(-1, 3), rays[..., 3:].reshape(-1, 3))
    assert np.allclose(hits.t[hits.hit], 5.0)      # t is depth: directions have unit depth


def test_rays_from_matrices_match_the_pinhole_helper():
    k = np.array([[100.0, 0, 32], [0, 100.0, 24], [0, 0, 1]])
    a = np.radians(30)
    r = np.array([[np.cos(a), 0, -np.sin(a)], [0, 1, 0], [np.sin(a), 0, np.cos(a)]])
    e = np.eye(4)
    e[:3, :3] = r
    e[:3, 3] = [0.5, -1.0, 2.0]
    rays = raytrace.create_rays_from_matrices(k, e, 64, 48)
    centre = -r.T @ e[:3, 3]
    assert np.allclose(rays[..., :3], centre)
    # Projecting a ray's point at depth 1 back through [R | t] and K gives its pixel centre.
    p = rays[10, 20, :3] + rays[10, 20, 3:]
    cam = r @ p + e[:3, 3]
    pix = k @ (cam / cam[2])
    assert np.allclose(pix[:2], [20.5, 10.5])


@pytest.mark.parametrize("call, message", [
    (lambda: raytrace.create_rays_pinhole(0, [0, 0, 0], [0, 0, 1], [0, 1, 0], 4, 4), "fov"),
    (lambda: raytrace.create_rays_pinhole(60, [0, 0, 0], [0, 0, 0], [0, 1, 0], 4, 4), "center"),
    (lambda: raytrace.create_rays_pinhole(60, [0, 0, 0], [0, 0, 1], [0, 0, 1], 4, 4), "up"),
    (lambda: raytrace.create_rays_pinhole(60, [0, 0, 0], [0, 0, 1], [0, 1, 0], 4.5, 4), "width"),
    (lambda: raytrace.create_rays_from_matrices(np.zeros((3, 3)), np.eye(4), 4, 4), "singular"),
    (lambda: raytrace.create_rays_from_matrices(np.eye(3), np.eye(3), 4, 4), "extrinsic"),
])
def test_bad_camera_arguments(call, message):
    with pytest.raises(RaytraceError, match=message):
        call()


def test_bounds_given_as_numbers_are_filled_once_for_each_size_and_value():
    """Scalar t_min and t_max are filled out for the kernels and kept for
    the next call of that size (rayscene._filled), by their bits."""
    from raytrace.cast.rays import _filled
    a = _filled(1000, np.inf)
    assert a is _filled(1000, np.inf) and (a == np.inf).all() and a.flags.writeable
    assert _filled(999, np.inf) is not a and len(_filled(999, np.inf)) == 999
    assert np.signbit(_filled(1000, -0.0)).all() and not np.signbit(_filled(1000, 0.0)).any()
    assert np.isnan(_filled(7, np.nan)).all()
    big = _filled(10_000_000, 1.0)
    assert big is not _filled(10_000_000, 1.0)     # too large to keep
    s = RayScene((SQUARE_V, SQUARE_F))
    o = np.tile([0.5, 0.25, 1.0], (1000, 1))
    for _ in range(2):
        h = s.cast_rays(o, DOWN, t_min=0.5, t_max=2.0)
        assert (h.t == 1.0).all()
    assert (s.cast_rays(o, DOWN, t_min=1.0).t == np.inf).all()


def test_a_trimesh_scene_is_its_meshes_where_its_nodes_place_them():
    """trimesh.load's answer for a file of several objects: each mesh a
    geometry, in the order of the graph's geometry nodes, moved as trimesh's
    own to_geometry() moves it (the same bits); points and paths left out."""
    import trimesh
    from trimesh.transformations import rotation_matrix, translation_matrix
    box, ball = trimesh.creation.box(), trimesh.creation.icosphere(2)
    moved = translation_matrix([3, 0, 0]) @ rotation_matrix(0.3, [0, 1, 0])
    placed = trimesh.Scene()
    placed.add_geometry(box, node_name="box")
    placed.add_geometry(trimesh.PointCloud(np.zeros((4, 3))), node_name="points")
    placed.add_geometry(ball, node_name="ball", transform=moved)
    o = np.array([[0.0, 0, 5], [3, 0.1, 5], [6, 0, 5]])
    d = np.array([[0.0, 0, -1]] * 3)
    h = RayScene(placed).cast_rays(o, d)
    assert h.geometry_id.tolist() == [0, 1, -1]
    assert np.array_equal(h.t, RayScene(placed.to_geometry()).cast_rays(o, d).t)
    with pytest.raises(RaytraceError, match="places no mesh with faces"):
        RayScene(trimesh.Scene([trimesh.PointCloud(np.zeros((4, 3)))]))
    with pytest.raises(RaytraceError, match=r"trimesh.Scene or a raytrace Scene; got builtins.object"):
        RayScene(object())


@pytest.mark.parametrize("accel", STRUCTURES)
@pytest.mark.parametrize("n", [1, 40, 3000])
def test_float32_rays_and_rows_of_six_are_read_in_place(monkeypatch, accel, n):
    """float32 origins and directions, (n, 3) or Open3D's (n, 6) rows, and
    float64 rows of 6 (create_rays_pinhole's), whole or sliced in two, go
    to the ray queries' kernels as they are (kernels/ray.py widen_rays),
    not copied first: the answers are those of the same rays in
    float64, bit for bit, one ray alone, in packets (PACKET_MIN rays or
    more) and over three chunks; no kernel compiles again for them."""
    from raytrace.cast import rays
    from raytrace.kernels import cast
    rng = np.random.default_rng(n)
    v, f = rng.normal(size=(90, 3)), rng.integers(0, 90, size=(60, 3))
    o32 = (rng.normal(size=(n, 3)) * 3).astype(np.float32)
    d32 = rng.normal(size=(n, 3)).astype(np.float32)
    t_max = rng.uniform(1, 6, n)
    s = RayScene((v, f), accel=accel)
    o64, d64 = o32.astype(np.float64), d32.astype(np.float64)
    ref = s.cast_rays(o64, d64, t_max=t_max)
    ref_any = s.occluded(o64, d64, t_max=t_max)
    ref_count = s.count_intersections(o64, d64, t_max=t_max)
    ref_list = s.list_intersections(o64, d64, t_max=t_max)
    kernels = (cast._closest_block, cast._closest_single, cast._occluded_block,
               cast._occluded_single, cast._counts_block, cast._listing_block)
    compiled = [len(k.signatures) for k in kernels]
    copied = []
    monkeypatch.setattr(rays, "_kernel_rows", lambda o, d: copied.append((o, d)))
    rows32 = np.concatenate([o32, d32], axis=1)
    rows64 = np.concatenate([o64, d64], axis=1)
    # float32 (n, 3) arrays, and float32 or float64 rows of 6, whole or as
    # the two slices of one array of rows.
    for args in ((o32, d32), (rows32, None), (rows32[:, :3], rows32[:, 3:]), (rows64, None),
                 (rows64[:, :3], rows64[:, 3:])):
        h = s.cast_rays(*args, t_max=t_max)
        for k in ("t", "prim_id", "u", "v"):
            assert np.array_equal(h[k].view(np.int64), ref[k].view(np.int64)), k
        assert np.array_equal(s.occluded(*args, t_max=t_max), ref_any)
        assert np.array_equal(s.count_intersections(*args, t_max=t_max), ref_count)
        listed = s.list_intersections(*args, t_max=t_max)
        for k in ("ray_splits", "t", "prim_id", "u", "v"):
            assert np.array_equal(listed[k], ref_list[k]), k
    assert copied == [] and [len(k.signatures) for k in kernels] == compiled
    assert ref.hit.any() and not ref.hit.all() or n == 1


def test_rays_in_other_layouts_are_copied_on_two_threads_with_the_same_answers(monkeypatch):
    """Rays the kernels cannot read in place (slices of rows of 7, Fortran
    order, rows reversed, integers, one origin for all) give the
    answers of C float64 arrays, bit for bit; a large call's two copies
    run on two threads at once when the query has two."""
    import numba

    from raytrace.cast import rays
    from raytrace.kernels import threads
    rng = np.random.default_rng(7)
    v, f = rng.normal(size=(90, 3)), rng.integers(0, 90, size=(60, 3))
    n = rays.PARALLEL_COPY_MIN
    o = np.round(rng.normal(size=(n, 3)) * 3)
    d = rng.normal(size=(n, 3))
    s = RayScene((v, f), accel="bvh")
    ref = s.cast_rays(o, d)
    assert ref.hit.any() and not ref.hit.all()
    seven = np.concatenate([o, np.zeros((n, 1)), d], axis=1)    # rows with a column between
    flipped = (o[::-1].copy()[::-1], d[::-1].copy()[::-1])
    runs = []
    real = threads.run_on_threads
    monkeypatch.setattr(threads, "run_on_threads", lambda jobs: (runs.append(
        [getattr(job, "func", None) is rays._copy_rows for job in jobs]), real(jobs)))
    for args in ((seven[:, :3], seven[:, 4:]), (np.asfortranarray(o), np.asfortranarray(d)), flipped,
                 (o.astype(np.int64), d), (o[0], d)):
        h = s.cast_rays(*args)
        want = ref if args[0].ndim == 2 else s.cast_rays(np.tile(o[0], (n, 1)), d)
        for k in ("t", "prim_id", "u", "v"):
            assert np.array_equal(h[k].view(np.int64), want[k].view(np.int64)), k
        assert np.array_equal(s.occluded(*args), want.hit)
    # Slices of 7, Fortran order and reversed rows copy both arrays: 3 layouts,
    # 2 queries each.  An integer or single origin is one copy, done at once.
    assert runs.count([True, True]) == (6 if numba.get_num_threads() > 1 else 0)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_bad_ray_among_rows_of_six_is_named(dtype):
    """A bad ray among float32 or float64 rows of 6, read in place, is named
    as one of (n, 3) arrays is: the direction's NaN by its row, not the
    origin's."""
    rows = np.tile(np.array([0.5, 0.5, 1.0, 0.0, 0.0, -1.0], dtype), (3000, 1))
    rows[1700, 4] = np.nan
    with pytest.raises(RaytraceError, match=r"directions\[1700\]: NaN or infinite value"):
        two_squares().cast_rays(rows)
    rows[1700, 4] = 0.0
    rows[5, 1] = np.inf
    with pytest.raises(RaytraceError, match=r"origins\[5\]: NaN or infinite value"):
        two_squares().occluded(rows, t_max=5.0)
