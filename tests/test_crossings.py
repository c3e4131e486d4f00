"""count_intersections, list_intersections and contains: every crossing of
a closed mesh counted once, also through its edges and vertices."""
import numpy as np
import pytest

from raytrace import RayScene, RaytraceError
from raytrace.scene.model import Camera, Mesh, Plane, Scene, Sphere
from tests.structures import STRUCTURES


def box(n=2):
    """The cube [-1, 1]^3, each face an n x n grid of squares cut into two
    triangles, wound outwards: vertices at exactly representable
    coordinates, so rays can pass exactly through edges and vertices."""
    verts, faces = [], []
    g = np.linspace(-1.0, 1.0, n + 1)
    for axis in range(3):
        for side in (-1.0, 1.0):
            base = len(verts)
            for a in g:
                for b in g:
                    p = [0.0, 0.0, 0.0]
                    p[axis], p[(axis + 1) % 3], p[(axis + 2) % 3] = side, a, b
                    verts.append(p)
            for i in range(n):
                for j in range(n):
                    q = [base + i * (n + 1) + j, base + (i + 1) * (n + 1) + j,
                         base + (i + 1) * (n + 1) + j + 1, base + i * (n + 1) + j + 1]
                    tri = [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
                    faces += tri if side > 0 else [t[::-1] for t in tri]
    v, f = np.array(verts), np.array(faces)
    # Merge the duplicated vertices along the cube's edges.
    uniq, inv = np.unique(v, axis=0, return_inverse=True)
    return uniq, inv.reshape(-1)[f]


def crossing_targets(v, f):
    """Points exactly on the mesh: its vertices, edge midpoints and face
    centroids where exactly representable (the grid's are)."""
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    mids = 0.5 * (v[e[:, 0]] + v[e[:, 1]])
    return np.unique(np.concatenate([v, mids]), axis=0)


@pytest.mark.parametrize("accel", STRUCTURES)
def test_rays_through_edges_and_vertices_cross_once(accel):
    v, f = box()
    rs = RayScene((v, f), accel=accel)
    targets = crossing_targets(v, f)
    # From a point inside (not the centre, so rays are not all axis-aligned
    # through the middle) straight through each vertex and edge midpoint.
    inside = np.array([0.25, -0.125, 0.375])
    counts = rs.count_intersections(inside, targets - inside)
    assert counts.tolist() == [1] * len(targets)
    # From outside, through the mesh and out again.
    outside = targets * 3.0 - 2.0 * inside
    counts = rs.count_intersections(outside, targets - outside)
    odd = counts % 2
    assert not odd.any(), targets[odd.astype(bool)]


def test_the_inclusive_test_would_count_a_diagonal_twice():
    """The control: the renderer's closest hit reports both triangles of a
    face at its diagonal, so counting by plain hits would say 2."""
    v, f = box()
    rs = RayScene((v, f))
    o = np.array([0.0, 0.0, 0.0])
    d = np.array([1.0, 0.5, 0.5])           # meets face x = 1 at (1, .5, .5): a diagonal
    hits = rs.list_intersections(o, d)
    assert len(hits["t"]) == 1 and hits["t"][0] == 1.0
    # Both triangles sharing that diagonal contain the point:
    tri = v[f]
    on_face = np.flatnonzero((tri[:, :, 0] == 1.0).all(axis=1))
    p = np.array([1.0, 0.5, 0.5])
    containing = [k for k in on_face if _in_triangle(p, tri[k])]
    assert len(containing) == 2


def _in_triangle(p, t):
    a, b, c = t
    n = np.cross(b - a, c - a)
    return all(np.dot(np.cross(y - x, p - x), n) >= 0 for x, y in ((a, b), (b, c), (c, a)))


def test_grazing_a_silhouette_edge_keeps_the_parity():
    v, f = box()
    rs = RayScene((v, f))
    # Along the plane y = 1 - 0, touching the cube's top edge at x = 1, y = 1
    # from outside: the surface folds away, so 0 or 2, never 1.
    o = np.array([3.0, 3.0, 0.25])
    d = np.array([-1.0, -1.0, 0.0])
    assert rs.count_intersections(o, d)[0] % 2 == 0


def test_list_intersections_layout_and_order():
    v, f = box()
    rs = RayScene(accel="bvh")
    rs.add_mesh(v, f)
    rs.add_mesh(v * 0.5, f)
    o = np.array([[-3.0, 0.1, 0.2], [-3.0, 5.0, 5.0], [0.0, 0.1, 0.2]])
    d = np.array([1.0, 0.0, 0.0])
    h = rs.list_intersections(o, d)
    assert h["ray_splits"].tolist() == [0, 4, 4, 6]
    assert h["ray_id"].tolist() == [0, 0, 0, 0, 2, 2]
    assert h["t"][:4] == pytest.approx([2.0, 2.5, 3.5, 4.0], rel=1e-15)
    assert h["geometry_id"][:4].tolist() == [0, 1, 1, 0]
    assert np.allclose(h["point"][:4, 0], [-1, -0.5, 0.5, 1])
    assert np.allclose(h["normal"][:4], [[-1, 0, 0], [-1, 0, 0], [1, 0, 0], [1, 0, 0]])
    assert rs.count_intersections(o, d).tolist() == [4, 0, 2]
    assert rs.count_intersections(o, d, max_hits=3).tolist() == [3, 0, 2]
    # Both ends exclusive: of ray 0's hits at 2, 2.5, 3.5 and 4, two remain.
    assert rs.count_intersections(o, d, t_min=2.0, t_max=4.0).tolist() == [2, 0, 0]
    assert rs.count_intersections(o, d, t_min=0.5, t_max=4.0).tolist() == [3, 0, 1]
    assert len(rs.list_intersections(o, d, max_hits=1)["t"]) == 2


def _layers(n_layers, copies=1):
    """n_layers unit squares in the planes z = 1 .. n_layers, each made of
    two triangles and repeated ``copies`` times, the faces shuffled so no
    structure meets them in order of z."""
    v, f = [], []
    for z in range(1, n_layers + 1):
        k = len(v)
        v += [[-1, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]]
        f += [[k, k + 1, k + 2], [k, k + 2, k + 3]] * copies
    order = np.random.default_rng(5).permutation(len(f))
    return np.array(v, float), np.array(f)[order]


@pytest.mark.parametrize("accel", STRUCTURES)
def test_many_hits_come_nearest_first(accel):
    """A ray through 40 layers lists 40 hits in order of t, more than one
    round of the in-place sort handles; max_hits keeps the nearest."""
    v, f = _layers(40)
    rs = RayScene((v, f), accel=accel)
    o = np.array([[0.25, 0.125, 0.0], [0.5, -0.25, 50.0]])
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    h = rs.list_intersections(o, d)
    assert h.ray_splits.tolist() == [0, 40, 80]
    assert h.t[:40].tolist() == list(range(1, 41))
    assert h.t[40:].tolist() == list(range(10, 50))
    z = v[f[h.prim_id][:, 0], 2]      # each hit's layer
    assert np.array_equal(z[:40], h.t[:40]) and np.array_equal(z[40:], 50 - h.t[40:])
    near = rs.list_intersections(o, d, max_hits=5)
    assert near.ray_splits.tolist() == [0, 5, 10]
    assert near.t.tolist() == [1, 2, 3, 4, 5, 10, 11, 12, 13, 14]
    assert near.ray_id.tolist() == [0] * 5 + [1] * 5
    assert np.array_equal(near.point, np.concatenate([h.point[:5], h.point[40:45]]))


def test_rays_listed_in_blocks_and_traversed_again_give_the_same_hits(monkeypatch):
    """Rays with 0 to 12 hits, more in all than the rows reserved (4 a
    ray), taken in slabs of 8 rows: some rays' hits overrun a slab and go
    into the next, some find the rows spent and are traversed again; then
    the same rays in blocks of two (a small LISTING_ROWS): the same rows,
    in order, and the counters of one traversal a ray."""
    from raytrace.cast import rayscene
    from raytrace.kernels import cast
    monkeypatch.setattr(cast, "SLAB", 8)
    run_listing, runs = rayscene._run_listing, []

    def spy(prepared, rays, rows, start=None, check=True):
        runs.append(start is None)
        return run_listing(prepared, rays, rows, start, check)
    monkeypatch.setattr(rayscene, "_run_listing", spy)
    v, f = _layers(12)
    rs = RayScene((v, f))
    n = 40
    o = np.column_stack([(np.arange(n) % 28 - 14) / 16, np.full(n, 0.125), np.zeros(n)])
    o[::7, 0] = 5.0                                 # beside the layers: no hit
    d = np.tile([0.0, 0.0, 1.0], (n, 1))
    t_max = np.arange(n) % 14 + 0.5                 # 0 to 12 layers
    h = rs.list_intersections(o, d, t_max=t_max)
    want = [0 if o[i, 0] == 5.0 else min(int(t_max[i]), 12) for i in range(n)]
    assert np.diff(h.ray_splits).tolist() == want and sum(want) > n * rayscene.LISTING_GUESS
    assert runs == [True, False]        # slabs, then the rays not written, again
    for i in range(n):
        assert h.t[h.ray_splits[i]:h.ray_splits[i + 1]].tolist() == list(range(1, want[i] + 1))
    monkeypatch.setattr(rayscene, "LISTING_ROWS", 2 * rayscene.LISTING_GUESS)
    blocks = rs.list_intersections(o, d, t_max=t_max)
    for k in ("ray_splits", "t", "prim_id", "u", "v"):
        assert np.array_equal(h[k], blocks[k]), k
    assert blocks.stats == h.stats
    assert h.stats["prim_hits"] == sum(want)
    d[33] = 0.0                                     # a bad ray in block 17 of 20
    with pytest.raises(RaytraceError, match=r"directions\[33\]: zero vector"):
        rs.list_intersections(o, d, t_max=t_max)


def test_hits_at_one_distance_go_by_primitive_id():
    """Each layer three times over: three hits at each t, the smaller face
    index first, every time."""
    v, f = _layers(12, copies=3)
    rs = RayScene((v, f))
    h = rs.list_intersections([0.25, 0.125, 0.0], [0.0, 0.0, 1.0])
    assert h.t.tolist() == [z for z in range(1, 13) for _ in range(3)]
    ids = h.prim_id.reshape(12, 3)
    assert np.all(np.diff(ids, axis=1) > 0)
    assert len(set(h.prim_id.tolist())) == 36


def test_spheres_have_two_roots():
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[Sphere((0, 0, 0), 1.0)])
    rs = RayScene(scene)
    assert rs.count_intersections([[0, 0, 5.0], [0.0, 0.0, 0.0]], [0, 0, -1.0]).tolist() == [2, 1]


@pytest.mark.parametrize("seed", range(4))
def test_every_structure_lists_the_same_hits(seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(60, 3))
    f = rng.integers(0, 60, size=(50, 3))
    o, d = rng.normal(size=(300, 3)) * 3, rng.normal(size=(300, 3))
    ref = None
    for accel in STRUCTURES:
        h = RayScene((v, f), accel=accel).list_intersections(o, d)
        got = [h[k] for k in ("ray_splits", "t", "prim_id", "u", "v")]
        if ref is None:
            ref = got
            # Nearest first, and never two hits of one primitive at one t.
            for i in range(len(o)):
                s = slice(h["ray_splits"][i], h["ray_splits"][i + 1])
                assert np.all(np.diff(h["t"][s]) >= 0)
        for a, b in zip(ref, got):
            assert np.array_equal(a, b, equal_nan=True), accel


@pytest.mark.parametrize("accel", STRUCTURES)
def test_listed_hits_are_the_counted_ones(accel):
    """Spheres (both roots), a plane and two meshes: each ray lists as many
    hits as count_intersections counts, each inside the interval, and the
    sphere's and plane's hits lie on them."""
    rng = np.random.default_rng(11)
    v, f = box(2)
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[
        Sphere((0.2, 0.1, 0.0), 0.7), Mesh(v, f), Mesh(v * 0.4 + 1.5, f),
        Sphere((2.0, 2.0, 2.0), 0.5), Plane((0.0, -1.5, 0.0), (0.0, 1.0, 0.0))])
    rs = RayScene(scene, accel=accel)
    o, d = rng.uniform(-3, 3, (1000, 3)), rng.normal(size=(1000, 3))
    t_min, t_max = rng.uniform(0, 0.5, 1000), rng.uniform(2, 8, 1000)
    h = rs.list_intersections(o, d, t_min=t_min, t_max=t_max)
    counts = rs.count_intersections(o, d, t_min=t_min, t_max=t_max)
    assert np.array_equal(np.diff(h.ray_splits), counts)
    assert counts.sum() > 300 and set(h.geometry_id.tolist()) == {0, 1, 2, 3, 4}
    assert np.all((h.t > t_min[h.ray_id]) & (h.t < t_max[h.ray_id]))
    on_sphere = h.geometry_id == 0
    r = np.linalg.norm(h.point[on_sphere] - [0.2, 0.1, 0.0], axis=1)
    assert np.allclose(r, 0.7, rtol=1e-12)
    assert np.allclose(h.point[h.geometry_id == 4][:, 1], -1.5, rtol=0, atol=1e-12)


@pytest.mark.parametrize("accel", STRUCTURES)
def test_contains(accel):
    v, f = box(3)
    rs = RayScene((v, f), accel=accel)
    rng = np.random.default_rng(7)
    p = rng.uniform(-1.5, 1.5, (3000, 3))
    far = np.abs(np.abs(p).max(axis=1) - 1.0) > 1e-9
    inside = rs.contains(p)
    assert np.array_equal(inside[far], (np.abs(p).max(axis=1) < 1.0)[far])
    assert np.array_equal(rs.contains(p, votes=3)[far], inside[far])
    # Points whose rays pass exactly through the grid's edges and vertices.
    q = np.array([[0.0, 0.0, 0.0], [1 / 3, 1 / 3, 1 / 3], [0.5, 0.0, 0.0], [1.5, 0.0, 0.0]])
    assert rs.contains(q).tolist() == [True, True, True, False]


def test_bad_max_hits_and_votes():
    v, f = box()
    with pytest.raises(RaytraceError, match="max_hits"):
        RayScene((v, f)).count_intersections([0, 0, 0.0], [1, 0, 0.0], max_hits=0)
    with pytest.raises(RaytraceError, match="votes"):
        RayScene((v, f)).contains([0, 0, 0.0], votes=2)


def test_a_vote_outweighs_a_hole():
    """A cube with one face triangle missing: a single ray from inside that
    leaves through the hole says outside, the three-ray vote says inside."""
    v, f = box(1)
    rs_full = RayScene((v, f))
    p = np.array([[0.25, -0.125, 0.75]])     # nearest face: z = 1
    from raytrace.cast.rayscene import _exit_directions
    (d,) = _exit_directions(p, rs_full._built().bounds(), 1)
    assert d[0, 2] > 0.99
    exit_tri = rs_full.cast_rays(p, d).prim_id[0]
    holed = RayScene((v, np.delete(f, exit_tri, axis=0)))
    assert rs_full.contains(p)[0]
    assert not holed.contains(p)[0]
    assert holed.contains(p, votes=3)[0]


def test_contains_leaves_the_box_the_short_way():
    """Each point's ray heads for the nearest face of the scene's box
    (votes=3: along each axis, to the nearer side), also from outside it."""
    from raytrace.cast.rayscene import _exit_directions
    bounds = (np.array([-1.0, -2.0, -3.0]), np.array([1.0, 2.0, 3.0]))
    # The last point is as near the x side as the y side: x, the first, goes.
    q = np.array([[0.9, 0.0, 0.0], [0.0, -1.9, 0.0], [0.0, 0.0, 2.5], [-5.0, 0.0, 0.0],
                  [0.0, 0.0, -0.5], [0.5, 1.5, 0.0]])
    (d,) = _exit_directions(q, bounds, 1)
    main = np.argmax(np.abs(d), axis=1)
    assert main.tolist() == [0, 1, 2, 0, 0, 0]
    assert np.sign(d[np.arange(6), main]).tolist() == [1, -1, 1, -1, -1, 1]
    three = _exit_directions(q, bounds, 3)
    assert [np.sign(x[0, a]) for a, x in enumerate(three)] == [1, -1, -1]   # a tie goes -
    assert all(np.all(x != 0) for x in three) and np.all(d != 0)


@pytest.mark.parametrize("seed", range(6))
def test_contains_sign_and_parity_agree_on_random_closed_meshes(seed):
    """A bumpy sphere (an icosphere's vertices moved in and out along their
    rays: closed and consistently wound) and random points, some very near
    the surface: contains, the sign of signed_distance and the parity of
    the count along any direction agree."""
    trimesh = pytest.importorskip("trimesh")
    rng = np.random.default_rng(seed)
    m = trimesh.creation.icosphere(subdivisions=2)
    v = m.vertices * rng.uniform(0.6, 1.4, (len(m.vertices), 1))
    rs = RayScene((v, m.faces))
    q = rng.uniform(-1.5, 1.5, (600, 3))
    # Points just off the surface: along a vertex's ray, 1e-9 in and out.
    k = rng.integers(0, len(v), 100)
    q = np.concatenate([q, v[k] * (1 - 1e-9), v[k] * (1 + 1e-9)])
    inside = rs.contains(q)
    assert np.array_equal(inside[-200:], [True] * 100 + [False] * 100)
    assert np.array_equal(inside, rs.signed_distance(q) < 0)
    for d in rng.normal(size=(3, 3)):
        assert np.array_equal(inside, rs.count_intersections(q, d) % 2 == 1)
