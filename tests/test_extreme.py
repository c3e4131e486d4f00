"""Stiff and extreme cases: rays exactly along box faces and through box
corners, coplanar objects, slivers, grazing rays, degenerate triangles,
scenes far from the origin or at extreme scales, and odd scenes (camera or
light inside an object, nothing at all, a single triangle).

Every structure must give brute force's answer bit for bit, and brute
force the answer worked out by hand.
"""
import importlib
import math

import numpy as np
import pytest

from raytrace import cast_rays, occluded
from raytrace.kernels.intersect import BOX_FAR_SCALE, ray_aabb
from raytrace.kernels.jit import python_callable
from raytrace.kernels.ray import make_ray
from raytrace.renderer.driver import render
from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene, Sphere
from raytrace.scene.transform import rotation
from tests.scene_transform import transform_scene
from tests.structures import EVERY_MODE, STRUCTURES
from tests.test_watertight import subdivided_box

# Per-ray kernel functions are compiled without Python wrappers (kernels/jit.py).
ray_aabb, make_ray = python_callable(ray_aabb), python_callable(make_ray)

EPS64 = np.finfo(np.float64).eps


def assert_same_as_brute(target, o, d, t_max=None):
    """Every structure's hits equal brute force's bit for bit (and so do
    its occlusion answers); returns brute force's hits."""
    base = cast_rays(target, o, d, accel="none", t_max=t_max)
    tm = np.inf if t_max is None else t_max
    base_occ = occluded(target, o, d, tm, accel="none")
    assert np.array_equal(base_occ, base.hit)
    for accel in STRUCTURES:
        h = cast_rays(target, o, d, accel=accel, t_max=t_max)
        for name in ("t", "prim_id", "object_id"):
            bad = np.flatnonzero(h[name] != base[name])
            assert bad.size == 0, (f"{accel}: {name} differs from brute force for {bad.size} rays, "
                                   f"e.g. o={o[bad[0]].tolist()} d={d[bad[0]].tolist()}: "
                                   f"{h[name][bad[0]]} against {base[name][bad[0]]}")
        assert np.array_equal(h.u, base.u, equal_nan=True) and np.array_equal(h.v, base.v, equal_nan=True)
        assert np.array_equal(occluded(target, o, d, tm, accel=accel), base_occ), accel
    return base


# --- compile options ---------------------------------------------------------

def package_modules(package):
    """Every module of a package, so kernels added later are checked too."""
    import pkgutil
    pkg = importlib.import_module(package)
    return [f"{package}.{m.name}" for m in pkgutil.iter_modules(pkg.__path__)]


def dispatchers(module_names):
    from numba.core.registry import CPUDispatcher
    for name in module_names:
        mod = importlib.import_module(name)
        for attr, obj in vars(mod).items():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == name:
                yield f"{name}.{attr}", obj


def test_kernels_use_numpy_errors_and_no_fastmath():
    """error_model="numpy": 1/0 is inf (the slab test relies on it), not a
    ZeroDivisionError.  No fastmath: it lets LLVM assume there are no inf
    or NaN, and the slab test and the watertight test use both."""
    found = dict(dispatchers(package_modules("raytrace.kernels")))
    assert {"raytrace.kernels.intersect.ray_triangle", "raytrace.kernels.intersect.ray_aabb",
            "raytrace.kernels.cast._closest_block", "raytrace.kernels.wavefront.run_stage",
            "raytrace.kernels.bounces.run_bounce_stage"} <= set(found)
    for name, disp in found.items():
        opts = disp.targetoptions
        assert not opts.get("fastmath"), name
        assert opts.get("error_model") == "numpy", name
    for name, disp in dispatchers(package_modules("raytrace.accel")):
        assert not disp.targetoptions.get("fastmath"), name
    # A thread's share of a batch kernel: without the reference-counting
    # runtime, releasing the GIL (kernels/threads.py runs it on each thread).
    for name in ("raytrace.kernels.cast._closest_block", "raytrace.kernels.cast._occluded_block",
                 "raytrace.kernels.wavefront.run_stage", "raytrace.kernels.bounces.run_bounce_stage"):
        assert found[name].targetoptions.get("_nrt") is False, name
        assert found[name].targetoptions.get("nogil") is True, name


def test_zero_direction_components_give_signed_infinite_inverses():
    ray = make_ray(1.0, 2.0, 3.0, 0.0, -0.0, 1.0)
    assert ray.inv_x == math.inf and ray.inv_y == -math.inf and ray.inv_z == 1.0
    ray = make_ray(1.0, 2.0, 3.0, -0.0, 0.5, 0.0)
    assert ray.inv_x == -math.inf and ray.inv_y == 2.0 and ray.inv_z == math.inf


# --- ray-box -----------------------------------------------------------------

def naive_slab(o, d, lo, hi):
    """The textbook slab test, without Ize's widened far bound."""
    inv = 1.0 / d
    tn = (lo - o) * inv
    tf = (hi - o) * inv
    t0 = np.maximum(np.minimum(tn, tf).max(axis=1), 0.0)
    t1 = np.maximum(tn, tf).min(axis=1)
    return t0 <= t1


@pytest.mark.parametrize("offset", [0.0, 1e5, -3e7])
def test_slab_far_bound_never_culls_a_touched_box(offset):
    """Rays that touch a box exactly along one of its edges: the exit from
    one slab and the entry into the next coincide, and rounding of
    (plane - o) / d decides the naive test.  Ize (2013): widening the far
    bound by 1 + 2 gamma(3) keeps every one of them."""
    rng = np.random.default_rng(7)
    n = 20000
    lo = offset + np.array([-1.0, -2.0, -0.5])
    hi = offset + np.array([1.5, 0.75, 2.0])
    # d has small integer components and o = edge point - 3 d is exact, so
    # the exact ray passes through the point (x = hi, y = lo, z inside) at t = 3.
    d = rng.integers(1, 1000, (n, 3)).astype(float) * rng.choice([-1.0, 1.0], (n, 3))
    d[:, 0] = np.abs(d[:, 0])       # leaving the x slab through hi ...
    d[:, 1] = np.abs(d[:, 1])       # ... as it enters the y slab through lo
    edge = np.column_stack([np.full(n, hi[0]), np.full(n, lo[1]),
                            lo[2] + rng.integers(1, 10, n) * (hi[2] - lo[2]) / 16])
    o = edge - 3.0 * d
    assert np.array_equal(o + 3.0 * d, edge)          # exact, so the ray does touch
    naive = naive_slab(o, d, lo, hi)
    assert (~naive).sum() > 0.05 * n                  # the case bites: rounding culls these
    LO, HI = lo[None, :], hi[None, :]
    got = np.array([ray_aabb(make_ray(*o[i], *d[i]), LO, HI, 0, np.inf) for i in range(2000)])
    assert np.all(got < np.inf)
    assert np.all(np.abs(got - 3.0) <= 8 * EPS64 * 3.0)


@pytest.mark.parametrize("offset", [0.0, 1e5])
def test_ray_aabb_flat_and_thin_boxes_far_from_the_origin(offset):
    for thickness in (0.0, 1e-9, 1e-6):
        lo = np.array([[offset - 1.0, offset + 0.25, offset - 1.0]])
        hi = lo + [[2.0, thickness, 2.0]]
        r = make_ray(offset + 0.3, offset + 5.0, offset - 0.2, 0.0, -1.0, -0.0)
        t = ray_aabb(r, lo, hi, 0, np.inf)
        assert t == pytest.approx(4.75 - thickness, abs=1e-9)
        # In the box's plane, along it: 0 * inf is NaN, which counts as inside.
        r = make_ray(offset - 5.0, offset + 0.25, offset + 0.5, 1.0, 0.0, 0.0)
        assert ray_aabb(r, lo, hi, 0, np.inf) == pytest.approx(4.0, abs=1e-9)
        # Starting inside (or on) the box: entry clamped to 0.
        r = make_ray(offset + 0.5, offset + 0.25, offset, 0.3, 0.0, 0.7)
        assert ray_aabb(r, lo, hi, 0, np.inf) == 0.0
        # Just beside it, parallel: a miss.
        r = make_ray(offset - 5.0, offset + 0.25 + thickness + 1e-6, offset, 1.0, 0.0, -0.0)
        assert ray_aabb(r, lo, hi, 0, np.inf) == np.inf
    assert BOX_FAR_SCALE > 1.0


@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e4])
@pytest.mark.parametrize("shift", [0.0, 1e5])
def test_rays_along_box_faces_edges_and_from_its_surface(scale, shift):
    """An axis-aligned box mesh (its triangles lie exactly on its own
    bounding box's faces) and axis-parallel rays with exact +-0.0
    components: lying in a face's plane, running along an edge, starting on
    the surface (inwards: hit the far side; outwards: nothing), and from
    inside."""
    v, f = subdivided_box(levels=1)
    v = v * scale + shift
    rng = np.random.default_rng(11)
    k = 200
    inner = rng.uniform(-0.9, 0.9, (k, 2)) * scale + shift
    hi, lo = 1.0 * scale + shift, -1.0 * scale + shift
    far = -5.0 * scale + shift
    o, d, expect_t, expect_hit = [], [], [], []

    def add(origins, direction, t, hit=True):
        o.append(origins)
        d.append(np.tile(direction, (len(origins), 1)))
        expect_t.append(np.full(len(origins), t))
        expect_hit.append(np.full(len(origins), hit))

    for zx, zy in ((0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0)):
        z = np.column_stack
        add(z([np.full(k, hi), inner[:, 1], np.full(k, far)]), [zx, zy, 1.0], 4.0 * scale)  # in x = hi
        add(z([inner[:, 0], np.full(k, lo), np.full(k, far)]), [zx, zy, 1.0], 4.0 * scale)  # in y = lo
        add(z([np.full(1, hi), np.full(1, lo), np.full(1, far)]), [zx, zy, 1.0], 4.0 * scale)  # an edge
        add(z([inner[:, 0], inner[:, 1], np.full(k, lo)]), [zx, zy, 1.0], 2.0 * scale)      # on -z face, in
        add(z([inner[:, 0], inner[:, 1], np.full(k, lo)]), [zx, zy, -1.0], np.inf, False)   # on it, out
        add(z([inner[:, 0], inner[:, 1], np.full(k, shift)]), [zx, zy, -1.0], 1.0 * scale)  # inside
    o, d = np.concatenate(o), np.concatenate(d)
    expect_t, expect_hit = np.concatenate(expect_t), np.concatenate(expect_hit)
    h = assert_same_as_brute((v, f), o, d)
    assert np.array_equal(h.hit, expect_hit)
    tol = 16 * EPS64 * (abs(shift) + 6 * scale)
    assert np.all(np.abs(h.t[expect_hit] - expect_t[expect_hit]) <= tol)
    # +0.0 and -0.0 give the same answers.
    n4 = len(o) // 4
    for q in range(1, 4):
        assert np.array_equal(h.t[q * n4:(q + 1) * n4], h.t[:n4])
        assert np.array_equal(h.prim_id[q * n4:(q + 1) * n4], h.prim_id[:n4])


# --- coplanar objects: the cull against the best hit so far ----------------

def grid_quad(n, z, offset):
    """An n x n grid of quads over [0, 1]^2 at height z, two triangles each."""
    xs = np.linspace(0.0, 1.0, n + 1)
    x, y = np.meshgrid(xs, xs)
    v = np.column_stack([x.ravel() + offset, y.ravel() + offset, np.full(x.size, z)])
    i = np.arange(n)
    a = (i[:, None] * (n + 1) + i[None, :]).ravel()
    f = np.concatenate([np.column_stack([a, a + 1, a + n + 2]), np.column_stack([a, a + n + 2, a + n + 1])])
    return v, f


@pytest.mark.parametrize("offset", [0.0, 1e5])
@pytest.mark.parametrize("gap", [0.0, 1.0])     # in ulps of the height
def test_coplanar_objects_resolve_like_brute_force(offset, gap):
    """Two overlapping flat meshes, as separate objects, in one plane (or
    one ulp apart): the hits of the two are a few ulps apart, and a box cull
    against the best hit so far must not pick the farther one.  Before the
    per-object boxes were padded, bvol disagreed with brute force on ~1% of
    these rays."""
    z = 0.3 + offset
    z2 = z + gap * np.spacing(z)
    m = Material()
    objs = [Mesh(*grid_quad(3, z, offset), m), Mesh(*grid_quad(5, z2, offset), m),
            Mesh(*grid_quad(4, z, offset), m)]
    scene = Scene("coplanar", Camera((0, 0, 1), (0, 0, 0)), objs)
    rng = np.random.default_rng(5)
    n = 30000
    o = np.column_stack([rng.uniform(-1, 2, (n, 2)) + offset, rng.uniform(0.5, 3, n) + z])
    aim = np.column_stack([rng.uniform(0, 1, (n, 2)) + offset, np.full(n, z)])
    h = assert_same_as_brute(scene, o, aim - o)
    assert h.hit.all()
    if gap == 0.0:
        assert len(np.unique(h.object_id)) >= 2      # the ties do go both ways
    # From below too, and occlusion with t_max just past the hit.
    o[:, 2] = 2 * z - o[:, 2]
    h = assert_same_as_brute(scene, o, aim - o)
    t_max = np.nextafter(h.t, np.inf)
    assert_same_as_brute(scene, o, aim - o, t_max=t_max)


# --- slivers and grazing rays ------------------------------------------------

SLIVER_X = (0.5, 0.5 + 1e-6)      # a column 1e-6 wide
SLIVER_Y = (0.3, 0.3 + 1e-7)      # a row 1e-7 high


def sliver_mesh():
    """The unit square in z = 0 cut into 3 x 3 quads along x = SLIVER_X and
    y = SLIVER_Y: large triangles sharing long edges with slivers of aspect
    1e-6 and 1e-7 (and a 1e-6 x 1e-7 quad where they cross)."""
    xs = np.array([0.0, *SLIVER_X, 1.0])
    ys = np.array([0.0, *SLIVER_Y, 1.0])
    x, y = np.meshgrid(xs, ys)
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    f = []
    for j in range(3):
        for i in range(3):
            a = j * 4 + i
            f += [[a, a + 1, a + 5], [a, a + 5, a + 4]]
    return v, np.array(f)


@pytest.mark.parametrize("placement", ["axis-aligned", "tilted, at 1e5"])
def test_slivers_and_grazing_rays(placement):
    v, f = sliver_mesh()
    tri = v[f]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    sliver = area2 < 1e-5
    assert sliver.sum() == 10                          # four per strip, two where they cross
    if placement == "axis-aligned":
        R, shift = np.eye(3), np.zeros(3)
    else:
        R, shift = rotation((35.0, -20.0, 10.0)), np.array([1e5, -1e5, 1e5])
    world = v @ R.T + shift
    normal = R @ [0.0, 0.0, 1.0]
    rng = np.random.default_rng(2)
    n = 20000
    # (1) Steep rays (within 60 degrees of the normal) aimed inside the
    # sliver strips, away from their long edges by 10% of their width.
    aim = np.column_stack([rng.uniform(0.02, 0.98, n), rng.uniform(0.02, 0.98, n), np.zeros(n)])
    half = n // 2
    aim[:half, 0] = SLIVER_X[0] + (SLIVER_X[1] - SLIVER_X[0]) * rng.uniform(0.1, 0.9, half)
    aim[half:, 1] = SLIVER_Y[0] + (SLIVER_Y[1] - SLIVER_Y[0]) * rng.uniform(0.1, 0.9, n - half)
    theta = np.arccos(rng.uniform(0.5, 1.0, n))
    phi = rng.uniform(0, 2 * np.pi, n)
    up = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    up[::2, 2] *= -1                                   # half of them from below
    # (2) Grazing rays, 89.9 degrees from the normal, aimed anywhere inside.
    g_aim = np.column_stack([rng.uniform(0.05, 0.95, (n, 2)), np.zeros(n)])
    el = np.radians(0.1)
    g_up = np.column_stack([np.cos(el) * np.cos(phi), np.cos(el) * np.sin(phi),
                            np.sin(el) * np.where(np.arange(n) % 2, 1.0, -1.0)])
    aim_all = np.concatenate([aim, g_aim]) @ R.T + shift
    o = aim_all + 3.0 * (np.concatenate([up, g_up]) @ R.T)
    d = aim_all - o
    h = assert_same_as_brute((world, f), o, d)
    assert h.hit.all()
    p = o + h.t[:, None] * d
    err = np.linalg.norm(p - aim_all, axis=1)
    # The watertight test's t is a ratio with the triangle's (sheared)
    # area, so its error grows as the triangle thins (pbrt-v4's bound has
    # |det| in the denominator): a few ulps of the coordinates divided by
    # the triangle's aspect (area / longest edge^2, 1e-7 for the thinnest),
    # and for grazing rays times 1 / sin(0.1 deg) = 573 as well.
    longest2 = np.max([((tri[:, i] - tri[:, j]) ** 2).sum(axis=1) for i, j in ((0, 1), (1, 2), (2, 0))],
                      axis=0)
    aspect = area2 / longest2
    tol = 64 * EPS64 * (1.0 + np.abs(shift).max()) / aspect[h.prim_id]
    tol[n:] *= 573
    assert np.all(err <= tol), (err / tol).max()
    assert np.all(np.abs((p - shift) @ normal) <= tol)
    # Where the triangles are not thin, that is a few ulps (times 573).
    fat = aspect[h.prim_id[n:]] > 0.1
    assert fat.mean() > 0.9 and err[n:][fat].max() < 64 * 573 * EPS64 * (1.0 + np.abs(shift).max())
    # The steep rays land on the sliver they were aimed at.
    assert sliver[h.prim_id[:n]].all()


# --- degenerate triangles ----------------------------------------------------

def mesh_with_degenerates():
    """A unit square (faces 0, 1), then a zero-area triangle (one point),
    a collinear one and one with a repeated vertex, all away from the
    square, and a 1e-6 sliver, which is thin but not degenerate."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],       # square
                  [3, 3, 0], [3, 3, 0], [3, 3, 0],                  # a point, three times
                  [2, 0, 0], [2.5, 0.5, 0], [3, 1, 0],              # collinear
                  [4, 0, 0], [5, 1, 0],                             # segment, with a repeat
                  [6, 0, 0], [7, 0, 0], [6.5, 1e-6, 0]], float)     # a sliver, kept
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 10], [12, 13, 14]])
    return v, f


def test_degenerate_triangles_are_dropped_counted_and_never_hit():
    v, f = mesh_with_degenerates()
    from raytrace.scene.flatten import flatten
    scene = Scene("degenerate", Camera((3.5, 0.5, 6), (3.5, 0.5, 0)), [Mesh(v, f)],
                  lights=[Light((3.5, 3.0, 5.0))])
    assert flatten(scene)[2]["degenerate_dropped"] == 3
    # Rays at every point of the degenerate triangles, from every side.
    rng = np.random.default_rng(4)
    pts = np.concatenate([np.tile([3.0, 3.0, 0.0], (50, 1)),
                          [2, 0, 0] + rng.uniform(0, 1, (50, 1)) * [1, 1, 0],
                          [4, 0, 0] + rng.uniform(0, 1, (50, 1)) * [1, 1, 0]])
    dirs = rng.normal(size=(len(pts), 3))
    h = assert_same_as_brute((v, f), pts - dirs, dirs)
    assert not h.hit.any()
    # Rays in the plane, along the collinear one's line: no area to hit.
    h = cast_rays((v, f), [[1.5, -0.5, 0.0], [3.5, -0.5, 0]], [[1, 1, 0.0], [1, 1, 0]], accel="none")
    assert not h.hit.any()
    # The sliver (face 5) and the square stay and are hit.
    h = cast_rays((v, f), [[6.5, 1e-7, 1], [0.3, 0.6, 1]], [[0, 0, -1.0]] * 2, accel="none")
    assert h.prim_id.tolist() == [5, 1]
    for accel in STRUCTURES:
        r = render(scene, accel=accel, shadows="hard", width=24, height=16, aov=True)
        assert r.stats["degenerate_dropped"] == 3 and r.stats["triangles"] == 3
        assert set(np.unique(r.aovs["primid"])) <= {-1, 0, 1, 2}
    from raytrace.renderer.stats import format_table
    line = [ln for ln in format_table(r.stats).splitlines() if ln.startswith("Degenerate")]
    assert line and line[0].split()[-1] == "3"


# --- odd scenes --------------------------------------------------------------

FLAT_WHITE = Material(color=(1.0, 1.0, 1.0), ambient=0.2, diffuse=0.8, specular=0.0, shininess=1.0)


@pytest.mark.parametrize("accel", STRUCTURES)
def test_camera_inside_a_sphere_sees_only_its_inside(accel):
    scene = Scene("inside", Camera((0.1, 0.2, 0.0), (1.0, 0.3, -2.0), fov=120.0),
                  [Sphere((0.0, 0.0, 0.0), 2.0, FLAT_WHITE)],
                  lights=[Light((0.5, 0.5, 0.5), size=0.5)])
    shadows = "soft" if accel in EVERY_MODE else "hard"     # tests/structures.py
    r = render(scene, accel=accel, shadows=shadows, light_samples=4, pattern="random",
               width=32, height=24, aov=True)
    assert (r.aovs["primid"] == 0).all()
    c = r.stats["counters"]
    assert c["shading_points"] == 32 * 24 and c["primary_rays"] == 32 * 24
    p = np.array(scene.camera.eye)
    assert np.all((r.aovs["depth"] > 2.0 - np.linalg.norm(p) - 1e-6)
                  & (r.aovs["depth"] < 2.0 + np.linalg.norm(p) + 1e-6))
    # The light is inside too, and nothing stands between it and the wall.
    assert c["shadow_rays"] > 0 and c["occluded_rays"] == 0
    assert np.isfinite(r.linear).all() and (r.linear > 0.2 * 0.99).all()


@pytest.mark.parametrize("accel", STRUCTURES)
def test_camera_inside_a_closed_box_sees_only_the_box(accel):
    v, f = subdivided_box(levels=2, rotate=True)
    scene = Scene("in a box", Camera((0.1, -0.2, 0.3), (1.0, 0.3, -2.0), fov=150.0),
                  [Mesh(v, f, FLAT_WHITE)], lights=[Light((0.2, 0.5, 0.1))])
    r = render(scene, accel=accel, shadows="hard", width=48, height=36, aov=True)
    assert (r.aovs["primid"] >= 0).all()
    assert r.stats["counters"]["occluded_rays"] == 0


@pytest.mark.parametrize("accel", STRUCTURES)
def test_light_inside_a_closed_object_leaves_only_ambient(accel):
    """A light inside a closed box and one inside a sphere, the camera and
    the ground outside: every shadow ray is blocked, so the picture equals
    the same scene with no lights at all (ambient only)."""
    v, f = subdivided_box(levels=1, rotate=True)
    objs = [Mesh(v * 0.8 + [0.0, 1.5, 0.0], f, FLAT_WHITE),
            Sphere((2.5, 1.0, 0.0), 0.9, FLAT_WHITE),
            Plane((0, 0, 0), (0, 1, 0), FLAT_WHITE)]
    lights = [Light((0.05, 1.55, -0.05), size=0.3), Light((2.45, 1.1, 0.1), size=0.3)]
    scene = Scene("shut in", Camera((1.0, 3.0, 6.0), (1.0, 0.8, 0.0)), objs, lights=lights)
    dark = Scene("dark", scene.camera, objs, lights=[])
    kw = dict(accel=accel, width=48, height=36)
    for shadows in ("hard", "soft") if accel in EVERY_MODE else ("hard",):
        r = render(scene, shadows=shadows, light_samples=9, **kw)
        c = r.stats["counters"]
        assert c["shadow_rays"] > 0 and c["occluded_rays"] == c["shadow_rays"]
        assert np.array_equal(r.linear, render(dark, shadows=shadows, **kw).linear)


@pytest.mark.parametrize("accel", STRUCTURES)
def test_empty_scene_is_background_only(accel):
    scene = Scene("empty", Camera((0, 1, 5), (0, 0, 0)), [], lights=[Light((0, 5, 0), size=1.0)],
                  background=(0.2, 0.4, 0.6))
    for shadows in ("none", "hard", "soft") if accel in EVERY_MODE else ("none", "hard"):
        r = render(scene, accel=accel, shadows=shadows, light_samples=4, width=24, height=16, aov=True)
        c = r.stats["counters"]
        assert c["primary_rays"] == 24 * 16
        for key in ("shadow_rays", "shading_points", "shadow_points", "occluded_rays",
                    "prim_tests", "prim_hits", "nodes_visited"):
            assert c[key] == 0, key
        assert r.stats["triangles"] == 0 and r.stats["objects"] == 0
        assert (r.aovs["primid"] == -1).all() and np.isinf(r.aovs["depth"]).all()
        # The sky's gradient of the background colour, by the ray's elevation.
        ratio = r.linear / np.array([0.2, 0.4, 0.6], np.float32)
        assert np.allclose(ratio, ratio[..., :1]) and 0.6 <= ratio.min() <= ratio.max() <= 1.0
    h = cast_rays(scene, [[0, 0, 0]], [[0, 0, 1]], accel=accel)
    assert h.prim_id.tolist() == [-1]


def test_empty_scene_file_through_the_cli(tmp_path, monkeypatch):
    import json

    from click.testing import CliRunner

    from raytrace.cli.main import main
    monkeypatch.chdir(tmp_path)
    (tmp_path / "empty.toml").write_text('[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n'
                                         '[[lights]]\nposition = [0, 5, 0]\n')
    r = CliRunner().invoke(main, ["empty.toml", "--width", "24", "--height", "16", "--json"])
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    assert stats["counters"]["primary_rays"] == 24 * 16 and stats["counters"]["shading_points"] == 0
    assert stats["triangles"] == stats["objects"] == 0
    assert (tmp_path / "empty.png").exists()


@pytest.mark.parametrize("accel", STRUCTURES)
def test_a_single_triangle(accel):
    v = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.5, 0.0]])
    scene = Scene("one", Camera((0.2, 0.6, 3.0), (0.0, 0.6, 0.0), fov=50.0),
                  [Mesh(v, np.array([[0, 1, 2]]), FLAT_WHITE)], lights=[Light((0, 1, 4), size=1.0)])
    shadows = "soft" if accel in EVERY_MODE else "hard"     # tests/structures.py
    r = render(scene, accel=accel, shadows=shadows, light_samples=4, width=32, height=24, aov=True)
    prim = r.aovs["primid"]
    assert set(np.unique(prim)) == {-1, 0}
    assert 0.05 < (prim == 0).mean() < 0.8
    c = r.stats["counters"]
    assert c["shading_points"] == (prim == 0).sum() and c["occluded_rays"] == 0
    base = render(scene, accel="none", shadows=shadows, light_samples=4, width=32, height=24)
    assert np.array_equal(r.linear, base.linear)


# --- whole scenes far from the origin and at extreme scales ------------------

def teapot_kw(accel):
    """Soft shadows for brute force and the default structure, hard for the
    others (tests/structures.py)."""
    return dict(shadows="soft" if accel in EVERY_MODE else "hard", light_samples=16, width=160,
                height=120)


@pytest.fixture(scope="module")
def unit_teapots():
    from raytrace.scene.builtin import teapot
    return {accel: render(teapot(), accel=accel, **teapot_kw(accel)) for accel in STRUCTURES}


@pytest.mark.parametrize("accel", STRUCTURES)
@pytest.mark.parametrize("scale, shift", [(1e-4, 0.0), (1e4, 0.0), (1.0, 1e5)])
def test_teapot_scaled_or_moved_far_away_looks_the_same(unit_teapots, accel, scale, shift):
    """Camera, lights (and the area light's size), the plane's point and
    the checker squares move with the scene.

    Tolerance.  Scaling changes nothing the renderer can see (measured:
    bit-identical linear radiance at 1e-4 and 1e4), so it must match
    exactly.  1e5 from the origin the coordinates keep 17 fewer bits (an
    ulp is 1.5e-11, not 1.1e-16), so hit points and normals move by ~1e-11:
    measured 4 of 19,200 pixels differing, by 3e-8 (float32 rounding of the
    sum), with every shadow ray's verdict unchanged.  Allowed: 0.1% of the
    pixels differing, by at most 1e-6 (1/300 of the smallest 8-bit step,
    3e-4 in linear radiance near black), and the same counters for every
    ray: a single shadow ray changing its verdict, a soft-shadow sample
    worth 1/16 of a light, fails the test.  (With the earlier shadow-ray
    offset of 2^-32 the figure was 17 pixels, by up to 0.02.)
    """
    from raytrace.scene.builtin import teapot
    base = unit_teapots[accel]
    r = render(transform_scene(teapot(), scale, shift), accel=accel, **teapot_kw(accel))
    diff = np.abs(r.linear - base.linear).max(axis=2)
    if shift == 0.0:
        assert np.array_equal(r.linear, base.linear)
    else:
        assert (diff > 0).mean() <= 1e-3 and diff.max() <= 1e-6
        assert (r.image != base.image).any(axis=2).mean() <= 1e-3
    c, cb = r.stats["counters"], base.stats["counters"]
    for key in ("primary_rays", "shading_points", "shadow_points", "shadow_rays", "occluded_rays"):
        assert c[key] == cb[key], key
