"""Uniform grid: build invariants against a slow Python overlap check, and
differential tests against brute force (results must be bit-identical)."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numba import njit

from raytrace.accel.grid.build import GRID_MAX_RES, Grid, _fill_cells, build_grid, grid_eps
from raytrace.accel.registry import build_structure as build_accel
from raytrace.cast.rays import _any_hit, _closest
from raytrace.kernels.cast import ray_scene
from raytrace.kernels.counters import BOX_TESTS, CELLS_VISITED, PRIM_TESTS
from raytrace.kernels.query import closest_hit, occluded
from raytrace.kernels.ray import make_ray
from raytrace.scene.flatten import flatten
from raytrace.scene.model import Camera, Mesh, Plane, Scene, Sphere

SETTINGS = dict(derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])


# -- helpers -----------------------------------------------------------------

def make_scene(meshes=(), spheres=(), planes=()):
    objs = [Mesh(np.asarray(v, float), np.asarray(f)) for v, f in meshes]
    objs += [Sphere(tuple(c), float(r)) for c, r in spheres]
    objs += [Plane(tuple(p), tuple(n)) for p, n in planes]
    geo, obj_ranges, _ = flatten(Scene("t", Camera((0, 0, 0), (0, 0, 1)), objs))
    return geo, obj_ranges


def _arrays(o, d, t_max):
    o, d, t_max = (np.ascontiguousarray(a, np.float64) for a in (o, d, t_max))
    return o, d, np.zeros(len(o)), t_max


def cast(geo, acc, o, d, t_max):
    return _closest(ray_scene(geo, acc), *_arrays(o, d, t_max))


def occ(geo, acc, o, d, t_max):
    return _any_hit(ray_scene(geo, acc), *_arrays(o, d, t_max))


@njit(error_model="numpy")
def _traverse_unchecked(geo, acc, o, d, cnt):
    out = []
    for i in range(o.shape[0]):
        ray = make_ray(o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2])
        h = closest_hit(geo, acc, ray, np.inf, cnt)
        out.append((h.t, h.prim, occluded(geo, acc, ray, np.inf, cnt)))
    return out


def traverse_unchecked(geo, acc, o, d):
    """(t, prim, occluded) of each ray, traced without the batch kernels'
    check of the ray."""
    from raytrace.kernels.cast import COLUMNS
    return _traverse_unchecked(geo, acc, o, d, np.zeros(COLUMNS, np.int64))


def assert_same_as_brute(geo, obj_ranges, o, d, t_max):
    none, _ = build_accel("none", geo, obj_ranges)
    grid, _ = build_accel("grid", geo, obj_ranges)
    (bt, bp, bu, bv), _ = cast(geo, none, o, d, t_max)
    (gt, gp, gu, gv), _ = cast(geo, grid, o, d, t_max)
    for name, b, g in (("t", bt, gt), ("prim", bp, gp), ("b1", bu, gu), ("b2", bv, gv)):
        bad = np.flatnonzero(~((b == g) | (np.isnan(b) & np.isnan(g))))
        assert bad.size == 0, (f"{name} differs for rays {bad[:5]}: brute {b[bad[:5]]} "
                               f"grid {g[bad[:5]]}; o={o[bad[:1]]} d={d[bad[:1]]}")
    bh, _ = occ(geo, none, o, d, t_max)
    gh, _ = occ(geo, grid, o, d, t_max)
    bad = np.flatnonzero(bh != gh)
    assert bad.size == 0, f"occlusion differs for rays {bad[:5]}: o={o[bad[:1]]} d={d[bad[:1]]}"
    return bp


def reference_cells(lo, hi, glo, cell, res):
    """Slow and obvious: for each cell, the primitives whose box overlaps the
    closed cell box (touching counts)."""
    out = {}
    for z in range(res[2]):
        for y in range(res[1]):
            for x in range(res[0]):
                i = np.array([x, y, z])
                c_lo = glo + i * cell
                c_hi = glo + (i + 1) * cell
                hit = np.all((lo <= c_hi) & (hi >= c_lo), axis=1)
                out[x + res[0] * (y + res[1] * z)] = set(np.flatnonzero(hit).tolist())
    return out


def check_csr(cell_start, cell_items, res, n):
    assert cell_start.dtype == np.int64 and cell_items.dtype == np.int64
    assert cell_start.shape == (int(np.prod(res)) + 1,)
    assert cell_start[0] == 0 and cell_start[-1] == len(cell_items)
    assert np.all(np.diff(cell_start) >= 0)
    assert np.all((cell_items >= 0) & (cell_items < n))
    for c in range(len(cell_start) - 1):
        ids = cell_items[cell_start[c]:cell_start[c + 1]]
        assert len(set(ids.tolist())) == len(ids), "primitive listed twice in a cell"


def check_lists(lo, hi, glo, cell, res, cell_start, cell_items, eps):
    """Every overlapping primitive is listed; nothing beyond the widened box is."""
    exact = reference_cells(lo, hi, glo, cell, res)
    wide = reference_cells(lo - 2 * eps, hi + 2 * eps, glo, cell, res)
    for c, want in exact.items():
        got = set(cell_items[cell_start[c]:cell_start[c + 1]].tolist())
        assert want <= got, f"cell {c} misses {want - got}"
        assert got <= wide[c], f"cell {c} lists far primitives {got - wide[c]}"


# -- build invariants --------------------------------------------------------

@settings(max_examples=40, **SETTINGS)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 30),
       flat=st.sampled_from([None, 0, 1, 2]), offset=st.sampled_from([0.0, 1e3]))
def test_build_lists_every_overlap(seed, n, flat, offset):
    rng = np.random.default_rng(seed)
    lo = rng.uniform(-1, 1, (n, 3)) + offset
    hi = lo + rng.uniform(0, 0.6, (n, 3)) * (rng.random((n, 1)) < 0.8)  # some points
    if flat is not None:  # every box in one plane: the grid must still have volume
        lo[:, flat] = hi[:, flat] = 0.25
    glo, ghi, cell, res, cell_start, cell_items = build_grid(lo, hi)
    assert glo.dtype == ghi.dtype == cell.dtype == np.float64 and res.dtype == np.int64
    assert np.all(cell > 0) and np.all((res >= 1) & (res <= GRID_MAX_RES))
    assert np.all(glo < lo.min(axis=0)) and np.all(ghi > hi.max(axis=0))
    np.testing.assert_allclose(glo + res * cell, ghi)
    assert res.max() == min(GRID_MAX_RES, max(1, round(3 * np.cbrt(n))))
    check_csr(cell_start, cell_items, res, n)
    check_lists(lo, hi, glo, cell, res, cell_start, cell_items, grid_eps(glo, ghi))


@settings(max_examples=20, **SETTINGS)
@given(seed=st.integers(0, 2**32 - 1))
def test_box_touching_a_cell_face_goes_into_both_cells(seed):
    """Boxes whose faces lie exactly on cell faces (as computed by glo + k * cell)."""
    rng = np.random.default_rng(seed)
    glo, ghi, cell, res, _, _ = build_grid(rng.uniform(-1, 0, (40, 3)), rng.uniform(0, 1, (40, 3)))
    k_lo = rng.integers(0, res + 1, (25, 3))
    k_hi = np.minimum(k_lo + rng.integers(0, 2, (25, 3)), res)
    lo, hi = glo + k_lo * cell, glo + k_hi * cell
    cell_start, cell_items = _fill_cells(lo, hi, glo, cell, res, grid_eps(glo, ghi))
    check_csr(cell_start, cell_items, res, len(lo))
    check_lists(lo, hi, glo, cell, res, cell_start, cell_items, grid_eps(glo, ghi))


def test_build_empty():
    glo, ghi, cell, res, cell_start, cell_items = build_grid(np.zeros((0, 3)), np.zeros((0, 3)))
    assert res.tolist() == [0, 0, 0] and cell_start.tolist() == [0] and cell_items.size == 0
    assert np.all(cell > 0)


def test_empty_grid_traversal_does_nothing():
    """Only a plane: the grid is empty, its traversal tests and counts nothing."""
    geo, obj_ranges = make_scene(planes=[((0, -1, 0), (0, 1, 0))])
    acc, _ = build_accel("grid", geo, obj_ranges)
    assert isinstance(acc, Grid) and acc.grid_res.tolist() == [0, 0, 0]
    o = np.array([[0.0, 1, 0], [0, 1, 0]])
    d = np.array([[0.0, -1, 0], [0, 1, 0]])
    (t, p, _, _), cnt = cast(geo, acc, o, d, np.full(2, np.inf))
    assert t.tolist() == [2.0, np.inf] and p.tolist() == [0, -1]
    assert cnt[BOX_TESTS] == cnt[CELLS_VISITED] == 0 and cnt[PRIM_TESTS] == 2  # the plane
    assert_same_as_brute(geo, obj_ranges, o, d, np.full(2, np.inf))


# -- traversal == brute force ------------------------------------------------

def heightfield(rng, k, flat):
    """k x k vertices on a jittered lattice: adjacent triangles share edges
    and vertices.  flat: every vertex at z = 0.5 (an axis-aligned sheet)."""
    xs, ys = np.meshgrid(np.linspace(-1, 1, k), np.linspace(-1, 1, k), indexing="ij")
    z = np.full_like(xs, 0.5) if flat else rng.uniform(-0.5, 0.5, xs.shape)
    v = np.stack([xs, ys, z], axis=-1).reshape(-1, 3)
    f = []
    for i in range(k - 1):
        for j in range(k - 1):
            a, b, c, e = i * k + j, i * k + j + 1, (i + 1) * k + j, (i + 1) * k + j + 1
            f += [(a, b, e), (a, e, c)] if rng.random() < 0.5 else [(a, b, c), (b, e, c)]
    return v, np.array(f)


def random_rays(rng, n, lo, hi, targets):
    """Origins inside and outside the bounds; directions random, with exact
    0.0 / -0.0 components, axis-parallel, or aimed at the given targets."""
    ext = hi - lo
    inside = rng.random(n) < 0.4
    o = np.where(inside[:, None], rng.uniform(lo, hi, (n, 3)),
                 rng.uniform(lo - 1.5 * ext - 0.1, hi + 1.5 * ext + 0.1, (n, 3)))
    d = rng.normal(size=(n, 3))
    kind = rng.integers(0, 4, n)
    zero = (rng.random((n, 3)) < 0.4) & (kind == 1)[:, None]
    d[zero] = np.where(rng.random(zero.sum()) < 0.5, 0.0, -0.0)
    axis = rng.integers(0, 3, n)
    for i in np.flatnonzero(kind == 2):  # exactly axis-parallel, signed zeros elsewhere
        d[i] = np.where(rng.random(3) < 0.5, 0.0, -0.0)
        d[i, axis[i]] = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2)
    aim = np.flatnonzero(kind == 3)
    if len(targets) and len(aim):
        tgt = targets[rng.integers(0, len(targets), len(aim))]
        d[aim] = tgt - o[aim]
        # Half of them axis-parallel onto the target: origin moved along one axis.
        ap = rng.random(len(aim)) < 0.5
        for i, t in zip(aim[ap], tgt[ap]):
            o[i] = t
            o[i, axis[i]] += rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 3) * ext.max()
            d[i] = 0.0
            d[i, axis[i]] = np.sign(t[axis[i]] - o[i, axis[i]])
    d[np.all(d == 0, axis=1)] = (0.3, -0.5, 0.7)
    return o, d


@settings(max_examples=300, **SETTINGS)
@given(seed=st.integers(0, 2**32 - 1), n_soup=st.integers(0, 25), k=st.integers(0, 5),
       flat=st.booleans(), n_sph=st.integers(0, 3), scale=st.sampled_from([1.0, 1e-3, 50.0]),
       offset=st.sampled_from([0.0, 7.25, -300.0]))
def test_grid_matches_brute_force(seed, n_soup, k, flat, n_sph, scale, offset):
    rng = np.random.default_rng(seed)
    meshes, targets = [], []
    if n_soup:
        # Mixed sizes: big triangles span many cells, small ones few.
        v0 = rng.uniform(-1, 1, (n_soup, 3))
        size = rng.choice([0.05, 0.4, 1.5], n_soup)[:, None]
        v = np.stack([v0, v0 + size * rng.normal(size=(n_soup, 3)),
                      v0 + size * rng.normal(size=(n_soup, 3))], axis=1).reshape(-1, 3)
        meshes.append((v * scale + offset, np.arange(3 * n_soup).reshape(-1, 3)))
    if k >= 2:
        hv, hf = heightfield(rng, k, flat)
        hv = hv * scale + offset
        meshes.append((hv, hf))
        # Shared vertices and shared edges' midpoints.
        targets = np.concatenate([hv, 0.5 * (hv[hf[:, 0]] + hv[hf[:, 2]])])
    spheres = [(rng.uniform(-1, 1, 3) * scale + offset, rng.uniform(0.05, 0.5) * scale)
               for _ in range(n_sph)]
    geo, obj_ranges = make_scene(meshes, spheres)
    if geo.tri_v0.shape[0] + geo.sph_center.shape[0] == 0:
        return
    lo = np.concatenate([geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center]).min(axis=0)
    hi = np.concatenate([geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center]).max(axis=0)
    # Cell lattice points: rays aimed at, or starting on, cell faces, edges
    # and corners exercise the DDA's start cell and tie-breaking.
    grid, _ = build_accel("grid", geo, obj_ranges)
    k = rng.integers(0, grid.grid_res + 1, (40, 3))
    lattice = grid.grid_lo + k * grid.grid_cell
    targets = np.concatenate([np.asarray(targets).reshape(-1, 3), lattice])
    o, d = random_rays(rng, 400, lo, hi, targets)
    snap = rng.random(o.shape) < 0.15
    o[snap] = lattice[rng.integers(0, len(lattice), o.shape), np.arange(3)][snap]
    t_max = np.where(rng.random(len(o)) < 0.5, np.inf,
                     rng.uniform(0, 3, len(o)) * scale / np.linalg.norm(d, axis=1))
    assert_same_as_brute(geo, obj_ranges, o, d, t_max)


def test_far_origins_and_odd_rays():
    """Origins far beyond the guard, a subnormal direction component, a
    zero direction: brute force's answer whatever the path."""
    rng = np.random.default_rng(5)
    hv, hf = heightfield(rng, 6, flat=False)
    geo, obj_ranges = make_scene([(hv, hf)], [((0.2, 0.1, 0.0), 0.3)])
    o = np.array([[1e12, 3e11, 0.1], [0.1, 0.2, 5.0], [0.1, 0.2, 5.0], [0.3, -0.2, 5.0],
                  [0.0, 0.0, 0.0]])
    d = np.array([[-1.0, -0.3, 0.0], [0.0, 0.0, -1.0], [5e-324, 0.0, -1.0], [0.0, 0.0, 0.0],
                  [1.0, 0.0, 0.0]])
    # The batch kernels refuse the zero direction (they check each ray), so
    # it goes to the traversals directly: a shadow ray from a point at a
    # light's position is one the renderer can make.
    ok = np.any(d != 0.0, axis=1)
    prim = assert_same_as_brute(geo, obj_ranges, o[ok], d[ok], np.full(ok.sum(), np.inf))
    assert prim[0] >= 0 and prim[1] >= 0 and prim[2] >= 0
    none, _ = build_accel("none", geo, obj_ranges)
    grid, _ = build_accel("grid", geo, obj_ranges)
    assert (traverse_unchecked(geo, none, o[~ok], d[~ok])
            == traverse_unchecked(geo, grid, o[~ok], d[~ok]))
    # The far ray and the subnormal one skip the DDA and test everything.
    grid, _ = build_accel("grid", geo, obj_ranges)
    for i in (0, 2):
        _, cnt = cast(geo, grid, o[i:i + 1], d[i:i + 1], np.full(1, np.inf))
        assert cnt[CELLS_VISITED] == 0 and cnt[PRIM_TESTS] == len(hf) + 1
    _, cnt = cast(geo, grid, o[1:2], d[1:2], np.full(1, np.inf))
    assert cnt[CELLS_VISITED] > 0 and cnt[PRIM_TESTS] < len(hf)


def sphere_mesh(n_u=32, n_v=17):
    """UV sphere: 2 * n_u * (n_v - 1) triangles, the pole ones degenerate."""
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)
    v = np.linspace(0, np.pi, n_v)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    pts = np.stack([np.sin(vv) * np.cos(uu), np.sin(vv) * np.sin(uu), np.cos(vv)], -1)
    pts = pts.reshape(-1, 3)
    f = []
    for i in range(n_u):
        for j in range(n_v - 1):
            a, b = i * n_v + j, ((i + 1) % n_u) * n_v + j
            f += [(a, b, b + 1), (a, b + 1, a + 1)]
    return pts, np.array(f)


def test_grid_tests_fewer_primitives_on_1k_mesh():
    v, f = sphere_mesh()
    geo, obj_ranges = make_scene([(v, f)])
    n_tris = geo.tri_v0.shape[0]
    assert n_tris >= 950
    rng = np.random.default_rng(1)
    o = np.tile([0.0, 0.0, 4.0], (2000, 1)) + rng.normal(scale=0.01, size=(2000, 3))
    d = np.column_stack([rng.uniform(-0.3, 0.3, (2000, 2)), -np.ones(2000)])
    t_max = np.full(len(o), np.inf)
    none, _ = build_accel("none", geo, obj_ranges)
    grid, _ = build_accel("grid", geo, obj_ranges)
    (bt, bp, bu, bv), b_cnt = cast(geo, none, o, d, t_max)
    (gt, gp, gu, gv), g_cnt = cast(geo, grid, o, d, t_max)
    assert np.array_equal(bt, gt) and np.array_equal(bp, gp)
    assert np.array_equal(bu, gu) and np.array_equal(bv, gv)
    assert (gp >= 0).mean() > 0.5
    assert b_cnt[PRIM_TESTS] == n_tris * len(o)
    assert g_cnt[PRIM_TESTS] * 20 < b_cnt[PRIM_TESTS]
    assert g_cnt[BOX_TESTS] == len(o) and g_cnt[CELLS_VISITED] >= len(o)


if __name__ == "__main__":
    pytest.main([__file__, "-q"])
