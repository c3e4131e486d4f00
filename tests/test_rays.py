"""The Python API's ray casting: hand-computed hits, the face-id map,
every structure against a slow reference, and bad input."""
import inspect
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raytrace
from raytrace import RaytraceError, cast_rays, occluded
from raytrace.scene.model import Camera, Material, Mesh, Plane, Scene, Sphere
from tests.structures import STRUCTURES

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [5, 5, 5]], float)
# Face 0 is degenerate (a repeated vertex): dropped when flattened, so the
# kernel's triangle 0 is the user's face 1.
F = np.array([[0, 1, 3], [0, 1, 2]])
FLAT = ("none", "bvol")


@pytest.mark.parametrize("accel", FLAT)
def test_hand_computed_hit(accel):
    h = cast_rays((V, F), [[0.2, 0.3, -1.0], [2.0, 2.0, -1.0]], [[0, 0, 2.0], [0, 0, 1.0]], accel=accel)
    # Direction (0, 0, 2): the plane z = 0 is half a direction-length away.
    assert h.t.tolist() == [0.5, np.inf]
    assert h.prim_id.tolist() == [1, -1]          # the user's face 1, not the kernel's 0
    assert h.u[0] == pytest.approx(0.2) and h.v[0] == pytest.approx(0.3)
    assert np.isnan(h.u[1]) and np.isnan(h.v[1])
    assert h.object_id.tolist() == [0, -1]
    assert h.hit.tolist() == [True, False]
    for name in ("t", "prim_id", "u", "v", "object_id"):
        assert h[name] is getattr(h, name)
    assert len(h) == 2 and set(h.keys()) >= {"t", "prim_id", "u", "v"}
    with pytest.raises(KeyError):
        h["distance"]
    assert h.stats["rays"] == 2 and h.stats["prim_tests"] >= 1


def test_barycentrics_rebuild_the_hit_point():
    rng = np.random.default_rng(3)
    o = np.column_stack([rng.uniform(0, 0.5, 50), rng.uniform(0, 0.5, 50), np.full(50, -2.0)])
    d = np.column_stack([np.zeros(50), np.zeros(50), rng.uniform(0.5, 3, 50)])
    h = cast_rays((V, F), o, d, accel="none")
    assert h.hit.all()
    a, b, c = (V[F[h.prim_id, k]] for k in range(3))
    p = (1 - h.u - h.v)[:, None] * a + h.u[:, None] * b + h.v[:, None] * c
    assert np.allclose(p, o + h.t[:, None] * d)


def test_t_is_in_units_of_the_direction_length():
    o = [0.25, 0.25, -3.0]
    ts = [cast_rays((V, F), o, [[0, 0, s]], accel="none").t[0] for s in (0.5, 1.0, 4.0)]
    assert ts == [6.0, 3.0, 0.75]


def test_t_max_is_exclusive():
    o, d = [[0.25, 0.25, -1.0]], [[0, 0, 1.0]]
    assert cast_rays((V, F), o, d, accel="none", t_max=1.0).prim_id[0] == -1
    assert cast_rays((V, F), o, d, accel="none", t_max=np.nextafter(1.0, 2)).prim_id[0] == 1
    assert not occluded((V, F), o, d, 1.0, accel="none")[0]
    assert occluded((V, F), o, d, 1.5, accel="none")[0]


def test_one_origin_for_many_directions_and_no_rays():
    h = cast_rays((V, F), [0.1, 0.1, 1.0], [[0, 0, -1.0], [0, 0, 1.0], [1, 1, -1.0]], accel="none")
    assert h.prim_id.tolist() == [1, -1, -1]
    e = cast_rays((V, F), np.zeros((0, 3)), np.zeros((0, 3)), accel="none")
    assert len(e) == 0 and e.t.shape == (0,)
    assert occluded((V, F), np.zeros((0, 3)), np.zeros((0, 3)), 1.0, accel="none").shape == (0,)


class DuckMesh:
    """What trimesh.Trimesh offers, and all cast_rays needs."""
    def __init__(self, vertices, faces):
        self.vertices, self.faces = vertices, faces


def test_mesh_like_targets():
    o, d = [[0.2, 0.3, -1.0]], [[0, 0, 1.0]]
    assert cast_rays(DuckMesh(V, F), o, d, accel="none").prim_id[0] == 1
    import trimesh
    tm = trimesh.Trimesh(V[:3], F[1:], process=False)
    h = cast_rays(tm, o, d, accel="bvol")
    assert h.prim_id[0] == 0 and h.t[0] == 1.0


def test_scene_target_names_objects():
    m = Material()
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[
        Plane((0, -1, 0), (0, 1, 0), m),
        Mesh(V + [0, 0, 2], F, m),
        Sphere((3, 0, 0), 1.0, m),
    ])
    o = [[0.2, 0.3, 5.0], [3, 0, 5.0], [10, 10, 5.0], [-4, 0, 5.0]]
    d = [[0, 0, -1.0], [0, 0, -1.0], [0, 0, -1.0], [0, -1.0, -1.0]]
    for accel in FLAT:
        h = cast_rays(scene, o, d, accel=accel)
        assert h.object_id.tolist() == [1, 2, -1, 0]
        assert h.prim_id.tolist() == [1, 0, -1, 0]
        assert h.t == pytest.approx([3.0, 4.0, np.inf, 1.0])
        assert not np.isnan(h.u[0]) and np.isnan(h.u[1:]).all()   # only triangles have (u, v)
        assert occluded(scene, o, d, 100.0, accel=accel).tolist() == [True, True, False, True]


def reference_t(v0, v1, v2, o, d):
    """Moller-Trumbore in plain NumPy: t of every (ray, triangle), inf for a miss."""
    e1, e2 = v1 - v0, v2 - v0
    out = np.full((len(o), len(v0)), np.inf)
    for i, (oi, di) in enumerate(zip(o, d)):
        p = np.cross(di, e2)
        det = np.einsum("ij,ij->i", e1, p)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = oi - v0
            u = np.einsum("ij,ij->i", s, p) * inv
            q = np.cross(s, e1)
            w = (q @ di) * inv
            t = np.einsum("ij,ij->i", e2, q) * inv
        ok = (det != 0) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)
        out[i] = np.where(ok, t, np.inf)
    return out


@settings(max_examples=25, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2 ** 32 - 1), n_tris=st.integers(1, 40))
def test_every_structure_agrees_with_a_reference(seed, n_tris):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-2, 2, (n_tris, 1, 3))
    tris = centres + rng.normal(0, 0.6, (n_tris, 3, 3))
    verts = tris.reshape(-1, 3)
    faces = np.arange(3 * n_tris).reshape(-1, 3)
    o = rng.uniform(-4, 4, (60, 3))
    d = rng.uniform(-2, 2, (60, 3)) - 0.3 * o     # roughly inwards, mixed lengths
    results = {a: cast_rays((verts, faces), o, d, accel=a) for a in STRUCTURES}
    base = results["none"]
    for a, h in results.items():   # bit-identical across structures
        assert np.array_equal(h.t, base.t) and np.array_equal(h.prim_id, base.prim_id), a
        assert np.array_equal(h.u, base.u, equal_nan=True), a
        assert np.array_equal(occluded((verts, faces), o, d, np.inf, accel=a), h.hit), a
    # Against the reference: the same rays hit, at the same distance, and
    # the triangle reported is one the reference hits at that distance
    # (two triangles can share it where they touch).
    ref = reference_t(tris[:, 0], tris[:, 1], tris[:, 2], o, d)
    ref_t = ref.min(axis=1)
    hit = np.isfinite(ref_t)
    assert np.array_equal(base.hit, hit)
    assert np.allclose(base.t[hit], ref_t[hit], rtol=1e-9)
    assert np.allclose(ref[hit, base.prim_id[hit]], ref_t[hit], rtol=1e-9)




def test_default_structure_is_bvh():
    assert inspect.signature(cast_rays).parameters["accel"].default == "bvh"
    assert inspect.signature(occluded).parameters["accel"].default == "bvh"


GOOD_O, GOOD_D = [[0.2, 0.3, -1.0]], [[0, 0, 1.0]]


@pytest.mark.parametrize("target, o, d, kw, message", [
    ((V, F), [[0, 0]], GOOD_D, {}, r"origins: expected shape \(n, 3\)"),
    # (1, 1, 3) is one ray of an image-shaped array now (README: any leading shape).
    ((V, F), GOOD_O, [[[0, 0]]], {}, r"directions: expected shape \(n, 3\)"),
    ((V, F), [["a", "b", "c"]], GOOD_D, {}, "origins: not convertible to float64"),
    ((V, F), [[1j, 0, 0]], GOOD_D, {}, "complex"),
    ((V, F), [[0, np.nan, 0]], GOOD_D, {}, r"origins\[0\]: NaN or infinite"),
    ((V, F), GOOD_O, [[0, 0, 1], [0, np.inf, 1]], {}, r"directions\[1\]: NaN or infinite"),
    ((V, F), GOOD_O, [[0, 0, 1], [0, 0, 0]], {}, r"directions\[1\]: zero vector"),
    ((V, F), GOOD_O, [[0, 0, 1], [0, 0, 1], [0, -0.0, 0.0]], {}, r"directions\[2\]: zero vector"),
    ((V, F), [[0, 0, 0], [0, 2e100, 0], [0, 0, 0], [3e100, 0, 0]], [[0, 0, 1]] * 4, {},
     r"origins\[1\]: a value beyond 1e\+100 .*2 such rows"),
    ((V, F), [[0, 0, 0], [1, 1, 1]], [[0, 0, 1]] * 3, {}, "differ in length"),
    ((V, F), GOOD_O, GOOD_D, dict(t_max=-1.0), r"t_max\[0\]: must be positive"),
    ((V, F), GOOD_O, GOOD_D, dict(t_max=0.0), "must be positive"),
    ((V, F), GOOD_O, GOOD_D, dict(t_max=np.nan), "must be positive"),
    ((V, F), GOOD_O, GOOD_D, dict(t_max=[1.0, 2.0]), r"t_max: expected a number or shape \(1,\)"),
    ((V, F), GOOD_O, GOOD_D, dict(t_max="far"), "t_max: not convertible"),
    ((V, F), GOOD_O, GOOD_D, dict(accel="octree"), "unknown acceleration structure 'octree'"),
    ((V, [[0, 1, 5]]), GOOD_O, GOOD_D, {}, "face 0 indexes a vertex out of range"),
    ((V, [[0, 1, -1]]), GOOD_O, GOOD_D, {}, "out of range"),
    ((V, [[0.0, 1.0, 2.0]]), GOOD_O, GOOD_D, {}, "face indices must be integers"),
    ((V, [0, 1, 2]), GOOD_O, GOOD_D, {}, r"faces must have shape \(m, 3\)"),
    ((V[:, :2], F), GOOD_O, GOOD_D, {}, r"vertices must have shape \(n, 3\)"),
    ((np.where(V == 5, np.nan, V), F), GOOD_O, GOOD_D, {}, "vertex 4 has a NaN"),
    (([["x", 0, 0]], [[0, 0, 0]]), GOOD_O, GOOD_D, {}, "vertices are not numbers"),
    ("teapot.obj", GOOD_O, GOOD_D, {}, "target must be"),
    ((V, F, F), GOOD_O, GOOD_D, {}, "target must be"),
])
def test_bad_input_raises_one_clear_error(target, o, d, kw, message):
    kw.setdefault("accel", "none")
    with pytest.raises(RaytraceError, match=message):
        cast_rays(target, o, d, **kw)


def test_occluded_needs_a_t_max():
    with pytest.raises(RaytraceError, match="t_max: required"):
        occluded((V, F), GOOD_O, GOOD_D, None, accel="none")


def test_import_is_light():
    code = ("import sys, raytrace; "
            "bad = [m for m in ('numba', 'trimesh') if m in sys.modules]; "
            "assert not bad, bad; print(raytrace.__all__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    for name in ("load_scene", "render", "cast_rays", "occluded"):
        assert name in out.stdout and callable(getattr(raytrace, name))


@pytest.mark.parametrize("name", ["whitted.toml", "glass_teapot.toml"])
def test_secondary_rays_hit_alike_in_every_structure(name):
    """The rays a render casts after the camera's, for every structure:
    from just off each surface the camera sees (the renderer's own offset),
    on both sides (reflected and refracted rays leave from opposite
    sides), towards points on and around each light (shadow rays: the
    unnormalised direction and t_max = 1) and in random directions (mirror
    and glass rays).  Hits must be bit-identical to brute force's.  Renders
    with soft shadows and with mirrors and glass are compared image for
    image only between brute force and the default structure
    (tests/structures.py): a structure enters the render kernel through
    these two queries alone."""
    from raytrace.cast.cameras import create_rays_pinhole
    from raytrace.cast.rayscene import RayScene
    from raytrace.kernels.render import RAY_OFFSET
    from raytrace.scene.assets import assets_dir
    from raytrace.scene.load import load_scene

    scene = load_scene(str(assets_dir() / name))
    cam = scene.camera
    rays = create_rays_pinhole(cam.fov, cam.look_at, cam.eye, cam.up, 64, 48).reshape(-1, 6)
    ref = RayScene(scene, accel="none")
    first = ref.cast_rays(rays[:, :3], rays[:, 3:])
    p, n = first.point[first.hit], first.normal[first.hit]
    eps = RAY_OFFSET * np.abs(p).max(axis=1, initial=1.0)[:, None]
    o = np.concatenate([p + eps * n, p - eps * n])
    rng = np.random.default_rng(0)
    d = rng.normal(size=o.shape)
    lights = np.array([light.position for light in scene.lights], float)
    targets = lights[rng.integers(len(lights), size=len(o))] + rng.uniform(-1, 1, o.shape)
    to_light = targets - o
    assert len(o) > 2000
    base = ref.cast_rays(o, d)
    base_shadow = ref.occluded(o, to_light, t_max=1.0)
    assert 0.05 < base.hit.mean() < 0.95 and 0.02 < base_shadow.mean() < 0.98
    for accel in STRUCTURES:
        rs = RayScene(scene, accel=accel)
        h = rs.cast_rays(o, d)
        assert np.array_equal(h.t, base.t) and np.array_equal(h.prim_id, base.prim_id), accel
        assert np.array_equal(h.geometry_id, base.geometry_id), accel
        assert np.array_equal(h.u, base.u, equal_nan=True), accel
        assert np.array_equal(h.v, base.v, equal_nan=True), accel
        assert np.array_equal(rs.occluded(o, to_light, t_max=1.0), base_shadow), accel
        assert np.array_equal(rs.occluded(o, d), base.hit), accel



def _root(a):
    """The array that owns a's memory."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


@pytest.mark.parametrize("n", [5, 4096])
def test_fresh_columns_are_separate_arrays_of_one_block(n):
    """Columns of SHARED_MIN_ROWS rows or more are views of one block;
    fewer, arrays of their own (cheaper to make, and malloc keeps them)."""
    from raytrace.cast.rays import SHARED_MIN_ROWS, fresh_columns
    point, prim, d2 = fresh_columns(n, ((np.float64, 3), (np.int64, 1), (np.float64, 1)))
    assert (point.shape, prim.shape, d2.shape) == ((n, 3), (n,), (n,))
    assert (point.dtype, prim.dtype, d2.dtype) == (np.float64, np.int64, np.float64)
    assert all(a.flags.c_contiguous and a.flags.writeable for a in (point, prim, d2))
    shared = _root(point) is _root(prim) is _root(d2)
    assert shared == (n >= SHARED_MIN_ROWS)
    point[:] = 1.5
    prim[:] = -7
    d2[:] = 2.5
    # No column overlaps another.
    assert (point == 1.5).all() and (prim == -7).all() and (d2 == 2.5).all()


def test_a_calls_answers_share_one_allocation():
    """t, the primitive ids and the barycentrics of a call of
    SHARED_MIN_ROWS rays or more come from one block, which malloc keeps
    for the next call (rays.fresh_columns); the face and
    geometry ids are each one gather from a table whose last row, -1, a
    miss's id reads (prepared._id_tables)."""
    from raytrace.cast.rays import SHARED_MIN_ROWS
    o = np.tile([[0.2, 0.3, -1.0], [5.0, 5.0, -1.0], [0.2, 0.3, -1.0]], (SHARED_MIN_ROWS, 1))
    h = cast_rays((V, F), o, [[0, 0, 1.0]], accel="bvh")
    assert _root(h.t) is _root(h._prim) is _root(h._raw_uv[0]) is _root(h._raw_uv[1])
    assert h.prim_id[:3].tolist() == [1, -1, 1] and h.geometry_id[:3].tolist() == [0, -1, 0]
