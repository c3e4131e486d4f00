"""The LLVM-level pieces: ray_aabb4 (float32) must enter every box the
exact ray enters, at an entry no later than the exact one, and few others,
since the BVH's bit-identical images rest on it; crossing_mask must
decide each triangle as the scalar crossing test does, or leave it to it;
and the
frame stack array must behave as an ordinary array."""
from fractions import Fraction
from types import SimpleNamespace

import numpy as np
import pytest
from numba import njit, prange

from raytrace.accel.bvh.boxes import box_bound
from raytrace.accel.bvh.build import leaf_corners
from raytrace.accel.bvh.layout import BOX, BVH, WIDTH, lane_entries
from raytrace.accel.bvh.simd import LEAF_LANES, crossing_mask, leaf_hits
from raytrace.accel.bvh.traverse import BOX32_RANGE, NEAR_LIMIT, box_ray, child_boxes
from raytrace.kernels.intersect import ray_triangle, ray_triangle_crossing
from raytrace.kernels.lowlevel import frame_array, row_window, take_rows, take_ticket
from raytrace.kernels.ray import make_crossing_ray, make_ray


@njit(error_model="numpy")
def simd_entries(acc, origins, dirs, t_max):
    """(n, m, 4) entry distances from ray_aabb4, for every ray against
    every node's 4 lanes, and its mask bits."""
    n, m = origins.shape[0], acc.node_box.shape[0]
    entry = np.empty((n, m, WIDTH))
    bits = np.empty((n, m, WIDTH), np.bool_)
    for i in range(n):
        ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                       dirs[i, 0], dirs[i, 1], dirs[i, 2])
        br = box_ray(acc, ray)
        for node in range(m):
            mask, d = child_boxes(acc.node_box, node, br, t_max[i])
            for j in range(WIDTH):
                entry[i, node, j] = d[j]
                bits[i, node, j] = (mask >> j) & 1
    return entry, bits


def exact_entry(lo, hi, o, d, t_max):
    """The exact ray o + t d (float64 values taken exactly) against the box
    [lo, hi] (float32 values), in rational arithmetic: (entry, exit) with
    entry = max(0, slab entries) and exit = min(t_max, slab exits); the
    ray enters the box where entry <= exit.  None: it never meets an axis's
    slab (parallel to it, outside)."""
    t0, t1 = Fraction(0), None if t_max == np.inf else Fraction(t_max)
    for a in range(3):
        la, ha, oa, da = (Fraction(float(x)) for x in (lo[a], hi[a], o[a], d[a]))
        if da == 0:
            if not la <= oa <= ha:
                return None
            continue
        tn, tf = sorted(((la - oa) / da, (ha - oa) / da))
        t0 = max(t0, tn)
        t1 = tf if t1 is None else min(t1, tf)
    return t0, t1


def _float(x):
    """A Fraction as a float, inf past float64's range."""
    try:
        return float(x)
    except OverflowError:
        return np.inf if x > 0 else -np.inf


def as_tree(lo, hi):
    """(k, 3) boxes -> a BVH whose nodes hold them 4 a node, unused lanes
    +inf, in the BVH's box type, rounded outwards as collapse_bvh4 rounds
    them (no children: only the boxes are tested here)."""
    m = -(-len(lo) // WIDTH)
    box = np.full((m, 6, WIDTH), np.inf, BOX)
    with np.errstate(over="ignore"):
        lo32, hi32 = lo.astype(BOX), hi.astype(BOX)
    lo32 = np.where(lo32 > lo, np.nextafter(lo32, BOX(-np.inf)), lo32)
    hi32 = np.where(hi32 < hi, np.nextafter(hi32, BOX(np.inf)), hi32)
    for k in range(len(lo)):
        box[k // WIDTH, :3, k % WIDTH] = lo32[k]
        box[k // WIDTH, 3:, k % WIDTH] = hi32[k]
    nothing = np.zeros((m, WIDTH), np.int64)
    return BVH(box, nothing, nothing, np.zeros(0, np.int64), box_bound(box),
               lane_entries(nothing, nothing), np.full((9, 3), np.nan))


def check(lo, hi, o, d, t_max, slack=1e-5, tight=True):
    """ray_aabb4 against exact_entry for every ray and box: every box the
    exact ray enters is entered, at an entry no later than the exact one
    and within ``slack`` (relative) of it, give or take 8 float32 ulps of
    the coordinates' magnitude along the ray's slowest axis (the rounding
    of its origin); with ``tight``, a box entered that the exact ray misses
    is missed by no more than that; unused lanes
    are never entered; the mask names the lanes entered.  Returns the (n,
    k) entries (inf: not entered)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    o, d, t_max = np.asarray(o, float), np.asarray(d, float), np.asarray(t_max, float)
    acc = as_tree(lo, hi)
    simd, bits = simd_entries(acc, o, d, t_max)
    used = ~np.isinf(acc.node_box[:, 0, :])
    assert np.all(simd[:, ~used] == np.inf)                 # unused lanes never entered
    assert np.array_equal(bits, simd < np.inf)              # the mask names the lanes entered
    entries = simd[:, used]
    boxes = [(acc.node_box[k // WIDTH, :3, k % WIDTH], acc.node_box[k // WIDTH, 3:, k % WIDTH])
             for k in range(len(lo))]
    size = max(1.0, np.abs(o).max(), np.abs(lo).max(), np.abs(hi).max())
    for i in range(len(o)):
        with np.errstate(over="ignore"):       # a subnormal direction component
            ulps = 8 * 2.0 ** -24 * size / np.abs(d[i][d[i] != 0]).min()
        for k, (blo, bhi) in enumerate(boxes):
            got = entries[i, k]
            ex = exact_entry(blo, bhi, o[i], d[i], t_max[i])
            scale = slack * max(1.0, abs(_float(ex[0])) if ex else 1.0) + ulps
            if ex is not None and (ex[1] is None or ex[0] <= ex[1]):
                assert got < np.inf, (i, k, "culled a box the ray enters")
                assert Fraction(float(got)) <= ex[0], (i, k, "entry later than the exact one")
                assert _float(ex[0]) - got <= scale, (i, k, got, _float(ex[0]))
            elif got < np.inf and tight:
                assert ex is not None and _float(ex[0] - ex[1]) <= scale, (i, k, "a clear miss entered")
    return entries


def test_random_boxes_and_rays():
    rng = np.random.default_rng(11)
    c = rng.standard_normal((40, 3))
    size = rng.random((40, 3)) * rng.choice([1e-6, 0.1, 1.0], (40, 1))
    lo, hi = c - size, c + size
    o = rng.standard_normal((300, 3)) * 3
    # aimed near a box's corner, so many rays graze it
    k = rng.integers(0, 40, 300)
    target = np.where(rng.random((300, 1)) < 0.5, lo[k], hi[k])
    d = target + rng.standard_normal((300, 3)) * 0.05 - o
    t_max = np.where(rng.random(300) < 0.5, np.inf, rng.random(300) * 5)
    e = check(lo, hi, o, d, t_max)
    hit = e < np.inf
    assert 0.02 < hit.mean() < 0.9     # both answers are tested


def test_origins_a_hair_from_a_face():
    """Origins that float32 cannot hold, within 1e-12 of a box's face on
    either side (shadow rays start on surfaces), leaving along every
    direction: rounding the origin to float32 must never cull the box."""
    rng = np.random.default_rng(5)
    lo, hi = np.array([[0.1, 0.2, 0.3]]), np.array([[0.7, 0.9, 1.1]])
    n = 400
    o = lo + rng.random((n, 3)) * (hi - lo)
    axis = rng.integers(0, 3, n)
    face = np.where(rng.random(n) < 0.5, lo[0, axis], hi[0, axis])
    o[np.arange(n), axis] = face + rng.choice([-1e-12, 0.0, 1e-12], n)
    d = rng.standard_normal((n, 3))
    check(lo, hi, o, d, np.full(n, np.inf))


def test_axis_parallel_rays_on_faces_and_edges():
    """Direction components of +0.0 and -0.0 with the origin in a face plane
    (0 * inf = NaN slab distances): the lane must keep the box wherever the
    exact ray touches it, for every sign of zero."""
    lo = np.array([[0.0, 0.0, 0.0], [-1.0, -1.0, -1.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    hi = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [3.0, 1.0, 0.0]])  # flat ones too
    origins, dirs = [], []
    for ox in (-0.5, 0.0, 0.5, 1.0, 1.5):
        for oy in (0.0, 0.5, 1.0):
            for dx, dy, dz in ((0.0, 0.0, 1.0), (-0.0, 0.0, 1.0), (0.0, -0.0, -1.0),
                               (1.0, 0.0, 0.0), (-1.0, -0.0, 0.0), (0.0, 1.0, -0.0),
                               (1.0, 1.0, 0.0), (-0.0, -1.0, -0.0)):
                origins.append((ox, oy, -2.0 if dz > 0 else 2.0 if dz < 0 else 0.0))
                dirs.append((dx, dy, dz))
    n = len(origins)
    e = check(lo, hi, origins, dirs, np.full(n, np.inf))
    assert (e < np.inf).any() and (e == np.inf).any()


def test_tiny_direction_components_are_cut_not_dropped():
    """Direction components near 1e-30 (inverse past NEAR_LIMIT, whose
    products would overflow float32) and float64 subnormals: the near
    inverse is cut, which may only enter more boxes (so no tightness:
    a ray beside a slab, nearly parallel to it, may enter)."""
    lo, hi = np.array([[-1.0, 0.25, -1.0], [2.0, -3.0, 0.5]]), np.array([[1.0, 0.5, 1.0], [3.0, 3.0, 0.75]])
    origins, dirs = [], []
    for tiny in (1e-30, -1e-30, 1e-300, 5e-324, 3e-19):
        for oy in (0.0, 0.25, 0.3, 0.5 + 1e-17, 0.6):
            origins.append((-5.0, oy, 0.0))
            dirs.append((1.0, tiny, 0.0))
            origins.append((2.5, oy, -5.0))
            dirs.append((tiny, tiny, 1.0))
    with np.errstate(over="ignore"):
        assert np.abs(1 / np.array(dirs)[:, 1]).max() > NEAR_LIMIT
    n = len(origins)
    e = check(lo, hi, origins, dirs, np.full(n, np.inf), tight=False)
    assert (e == np.inf).any()      # the exact axes still cull


def test_past_float32_range_every_used_lane_is_entered():
    """An origin or a box beyond BOX32_RANGE, or a direction whose inverse
    float32 cannot hold: the float32 test cannot bound the distances, so
    every used lane is entered (the ray visits the whole tree, as brute
    force would) and unused lanes still never are."""
    lo, hi = np.array([[1.0, 1, 1], [5.0, 5, 5]]), np.array([[2.0, 2, 2], [6.0, 6, 6]])
    far = np.array([[1e30, 0.0, 0.0], [0.0, -1e25, 0.0]])   # origins past the range
    e = check(lo, hi, far, np.array([[-1.0, 0.1, 0.2], [0.0, 1.0, 0.0]]), np.full(2, np.inf),
              tight=False)
    assert np.all(e < np.inf)
    # Directions so long that their inverses vanish in float32 (t itself
    # would underflow): unbounded too.
    huge = np.array([[1e50, 1e50, 1e50], [-1e45, 2e45, -3e45], [1e50, 0.0, 1e50]])
    e = check(lo, hi, np.array([[-5.0, 0, 0]] * 3), huge, np.full(3, np.inf), tight=False)
    assert np.all(e < np.inf)
    for far_box in (1e50, 1e20):     # past float32's range (stored as inf), and within it
        acc = as_tree(np.vstack([lo, [[far_box, 0, 0]]]), np.vstack([hi, [[2 * far_box, 1, 1]]]))
        assert acc.box_bound > BOX32_RANGE
        e, bits = simd_entries(acc, np.array([[0.0, 0, 0], [10.0, 10, 10]]),
                               np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]), np.full(2, np.inf))
        assert np.all(e[:, 0, :3] < np.inf) and np.all(e[:, 0, 3] == np.inf)
        assert np.array_equal(bits, e < np.inf)


@pytest.mark.parametrize("offset", [0.0, 1e5])
def test_rays_touching_a_box_edge_keep_it(offset):
    """Rays through a box edge (exact: integer directions, o = edge - 3 d),
    which a textbook slab test partly culls (test_extreme.py), are all
    kept, entering at 3 or a few float32 ulps of the coordinates before."""
    rng = np.random.default_rng(8)
    n = 500
    lo = offset + np.array([-1.0, -2.0, -0.5])
    hi = offset + np.array([1.5, 0.75, 2.0])
    d = rng.integers(1, 1000, (n, 3)).astype(float) * rng.choice([-1.0, 1.0], (n, 3))
    d[:, :2] = np.abs(d[:, :2])
    edge = np.column_stack([np.full(n, hi[0]), np.full(n, lo[1]),
                            lo[2] + rng.integers(1, 10, n) * (hi[2] - lo[2]) / 16])
    o = edge - 3.0 * d
    assert np.array_equal(o + 3.0 * d, edge)
    e = check(lo[None], hi[None], o, d, np.full(n, np.inf))
    assert np.all(e <= 3.0)      # and within check's few float32 ulps of it


def test_t_max_and_behind():
    """Entry beyond t_max, or a box wholly behind the origin: a miss; an
    origin inside: entry 0 (less a subnormal margin); t_max exactly at the
    entry: kept (inclusive)."""
    lo, hi = np.array([[1.0, -1, -1]]), np.array([[2.0, 1, 1]])
    o = np.array([[0.0, 0, 0], [0.0, 0, 0], [3.0, 0, 0], [1.5, 0, 0], [0.0, 0, 0]])
    d = np.array([[1.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    t_max = np.array([np.inf, 0.5, np.inf, np.inf, np.inf])
    e = check(lo, hi, o, d, t_max)[:, 0]
    assert 1.0 - 1e-5 < e[0] <= 1.0 and -1e-30 < e[3] <= 0.0
    assert e[1] == e[2] == e[4] == np.inf
    e = check(lo, hi, o[:1], d[:1], np.array([1.0]))[:, 0]
    assert 1.0 - 1e-5 < e[0] <= 1.0


@njit(error_model="numpy")
def crossing_masks(leaf_tris, v0, v1, v2, origins, dirs, t_min, t_max, partner):
    """For every ray and every column of leaf_tris: the crossing_mask hit
    and unsure bits, as (n_rays, n_columns) booleans, once from each half
    of the test (chunk g of 4 columns first, with chunk partner[g] second;
    then every chunk as a second); the ray's watertight constants (kx, ky,
    kz, sx, sy, okx, oky, okz); and the scalar crossing test's distance to
    each of the triangles v0, v1, v2 (inf: a miss)."""
    n, m = origins.shape[0], leaf_tris.shape[1] - 3
    hits = np.zeros((2, n, m), np.bool_)
    unsure = np.zeros((2, n, m), np.bool_)
    consts = np.empty((n, 8))
    scalar = np.empty((n, v0.shape[0]))
    for i in range(n):
        ray = make_crossing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                                dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])
        consts[i, 0], consts[i, 1], consts[i, 2] = ray.kx, ray.ky, ray.kz
        consts[i, 3], consts[i, 4] = ray.sx, ray.sy
        consts[i, 5], consts[i, 6], consts[i, 7] = ray.okx, ray.oky, ray.okz
        for c in range(partner.shape[0]):
            chunks = (4 * c, 4 * partner[c])
            mask = crossing_mask(leaf_tris, chunks[0], chunks[1], ray, t_max[i])
            for half in range(2):
                g = chunks[half]
                for j in range(min(4, m - g)):
                    hits[half, i, g + j] = (mask >> (4 * half + j)) & 1
                    unsure[half, i, g + j] = (mask >> (8 + 4 * half + j)) & 1
        for p in range(v0.shape[0]):
            scalar[i, p] = ray_triangle_crossing(ray, v0, v1, v2, p, t_max[i])[0]
    return hits, unsure, consts, scalar


def edge_signs(v0, v1, v2, consts):
    """The scalar test's edge functions written out in NumPy (the same
    operations in the same order; NumPy fuses no multiply-adds): (n_rays,
    n_tris) True where their signs are mixed (the first rejection), and
    where all three share a strict sign."""
    kx, ky, kz = (consts[:, k, None].astype(int) for k in range(3))
    sx, sy, okx, oky, okz = (consts[:, k, None] for k in range(3, 8))
    rows = np.arange(len(v0))[None, :]
    corners = []
    for v in (v0, v1, v2):
        x, y, z = v[rows, kx] - okx, v[rows, ky] - oky, v[rows, kz] - okz
        corners.append((x - sx * z, y - sy * z))
    (ax, ay), (bx, by), (cx, cy) = corners
    e = (bx * cy - by * cx, cx * ay - cy * ax, ax * by - ay * bx)
    neg = (e[0] < 0) | (e[1] < 0) | (e[2] < 0)
    pos = (e[0] > 0) | (e[1] > 0) | (e[2] > 0)
    strict = ((e[0] > 0) & (e[1] > 0) & (e[2] > 0)) | ((e[0] < 0) & (e[1] < 0) & (e[2] < 0))
    return neg & pos, strict


def grid_leaf(scale):
    """Triangles of a grid (with degenerate ones: a point, a segment) and
    two spheres' ids in shuffled slots, their leaf_tris, and rays aimed
    exactly at the grid's vertices, edge midpoints and the triangles'
    centroids, near them, and at random (a third along an axis)."""
    rng = np.random.default_rng(5)
    g = np.arange(4.0)
    x, y = np.meshgrid(g, g)
    a = np.column_stack([x.ravel(), y.ravel(), np.zeros(16)])
    quads = [(i, i + 1, i + 5, i + 4) for i in range(11) if i % 4 != 3]
    tris = [(a[p], a[q], a[r]) for p, q, r, s in quads] + [(a[p], a[r], a[s]) for p, q, r, s in quads]
    tris += [(a[0], a[0], a[0]), (a[0], a[5], a[10]), tuple(rng.standard_normal((3, 3)))]
    t = np.array(tris) * scale
    v0, v1, v2 = (np.ascontiguousarray(t[:, k]) for k in range(3))
    n_tris = len(t)
    # Slots in a shuffled order, with two spheres' ids (n_tris and above).
    prim_ids = rng.permutation(n_tris + 2)
    geo = SimpleNamespace(tri_v0=v0, tri_v1=v1, tri_v2=v2)
    leaf_tris = leaf_corners(geo, prim_ids)
    assert leaf_tris.shape == (9, n_tris + 5) and np.isnan(leaf_tris[:, -3:]).all()
    targets = np.concatenate([a, 0.5 * (a[:-1] + a[1:]), 0.5 * (a[:-4] + a[4:]),
                              t.mean(axis=1) / scale]) * scale
    n = len(targets)
    o = targets + rng.integers(-4, 5, (n, 3)) * scale + np.array([0.0, 0.0, 3.0]) * scale
    d = targets - o
    o2 = rng.standard_normal((200, 3)) * 3 * scale
    d2 = rng.standard_normal((200, 3))
    d2[:60] = np.eye(3)[rng.integers(0, 3, 60)] * rng.choice([-1.0, 1.0], (60, 1))
    d3 = targets * (1 + 1e-12) + 1e-13 * scale - o    # just beside them
    origins = np.concatenate([o, o2, o])
    dirs = np.concatenate([d, d2, d3])
    return v0, v1, v2, n_tris, prim_ids, leaf_tris, origins, dirs


@pytest.mark.parametrize("scale", [1.0, 1e-6, 1e8])
def test_crossing_mask_decides_as_the_scalar_test(scale):
    """Rays aimed exactly at vertices and edge midpoints of a grid of
    triangles (edge functions exactly 0), near them, and at random; axis
    directions; rays at the triangles' centroids; degenerate triangles (a
    point, a segment); each hit again with its interval cut at its exact
    distance and just past it, at either end.  Columns in leaf order
    (counting_copy), two of them spheres; each chunk of 4 tested as the
    first half of the 8 lanes and as the second, beside another chunk.
    Every lane with strictly signed edge functions hits exactly where the
    scalar crossing test hits; a lane with mixed signs is a miss; every
    other lane, and a sphere's, is left to the scalar test."""
    rng = np.random.default_rng(5)
    v0, v1, v2, n_tris, prim_ids, leaf_tris, origins, dirs = grid_leaf(scale)
    t_min = np.zeros(len(origins))
    t_max = np.full(len(origins), np.inf)

    n_chunks = (n_tris + 2 + 3) // 4
    partner = rng.permutation(n_chunks)     # every chunk once as each half

    def check(origins, dirs, t_min, t_max):
        both, unsure2, consts, t_hit = crossing_masks(leaf_tris, v0, v1, v2, origins, dirs,
                                                      t_min, t_max, partner)
        assert np.array_equal(both[0], both[1]) and np.array_equal(unsure2[0], unsure2[1])
        hits, unsure = both[0], unsure2[0]
        tri = prim_ids < n_tris
        assert unsure[:, ~tri].all() and not hits[:, ~tri].any()
        hits, unsure = hits[:, tri], unsure[:, tri]
        order = prim_ids[tri]
        scalar = t_hit[:, order] < np.inf
        mixed, strict = edge_signs(v0[order], v1[order], v2[order], consts)
        assert not (hits & unsure).any()
        assert np.array_equal(hits, scalar & strict)
        assert np.array_equal(unsure, ~mixed & ~strict)
        assert not (scalar & mixed).any()
        return hits, unsure, strict, t_hit[:, order]

    hits, unsure, strict, t_hit = check(origins, dirs, t_min, t_max)
    # Every kind of lane occurs: strict hits and misses, edge and vertex
    # lanes both ways.
    scalar = t_hit < np.inf
    assert hits.any() and (strict & ~hits).any()
    assert (unsure & scalar).any() and (unsure & ~scalar).any()
    # Each strict hit again, its interval ending exactly at its distance
    # (a miss) or just beyond (a hit), or starting there (a miss) or just
    # before (a hit).
    ray, lane = np.nonzero(hits)
    d_hit = t_hit[ray, lane]
    zero, inf = np.zeros_like(d_hit), np.full_like(d_hit, np.inf)
    cuts = [(zero, d_hit, False), (zero, d_hit * (1 + 1e-9), True),
            (d_hit, inf, False), (d_hit * (1 - 1e-9), inf, True)]
    for lo, hi, kept in cuts:
        hits2 = check(origins[ray], dirs[ray], lo, hi)[0]
        assert np.array_equal(hits2[np.arange(len(ray)), lane], np.full(len(ray), kept))


@njit(error_model="numpy")
def leaf_tests(leaf_tris, v0, v1, v2, origins, dirs, t_min, t_max):
    """For every ray and every column of leaf_tris, tested 4 columns at a
    time by leaf_hits: the hit and NaN bits, and t, b1, b2 (n_rays,
    n_columns); and the scalar test's (t, b1, b2) for each of the
    triangles v0, v1, v2."""
    n, m = origins.shape[0], leaf_tris.shape[1] - 3
    bits = np.zeros((2, n, m), np.bool_)
    found = np.full((3, n, m), np.nan)
    scalar = np.empty((3, n, v0.shape[0]))
    for i in range(n):
        ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                       dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])
        for g in range(0, m, LEAF_LANES):
            mask, t, b1, b2 = leaf_hits(leaf_tris, g, ray, t_max[i])
            for j in range(min(LEAF_LANES, m - g)):
                bits[0, i, g + j] = (mask >> j) & 1
                bits[1, i, g + j] = (mask >> (LEAF_LANES + j)) & 1
                found[0, i, g + j], found[1, i, g + j], found[2, i, g + j] = t[j], b1[j], b2[j]
        for p in range(v0.shape[0]):
            scalar[0, i, p], scalar[1, i, p], scalar[2, i, p] = ray_triangle(ray, v0, v1, v2, p,
                                                                             t_max[i])
    return bits, found, scalar


@pytest.mark.parametrize("scale", [1.0, 1e-6, 1e8])
def test_leaf_hits_is_the_scalar_test_bit_for_bit(scale):
    """leaf_hits (the single-ray traversal's leaf test, 4 slots at once) on
    grid_leaf's triangles and rays: a lane hits exactly where the scalar
    test hits, rays through shared edges and vertices included, at the
    same t, b1 and b2 bit for bit; a sphere's slot and the padding are
    NaN lanes, left to test_prim, and never hits.  Each hit again with its
    interval cut at its exact distance and just past it, at either end."""
    v0, v1, v2, n_tris, prim_ids, leaf_tris, origins, dirs = grid_leaf(scale)

    def check(t_min, t_max):
        bits, found, scalar = leaf_tests(leaf_tris, v0, v1, v2, origins, dirs, t_min, t_max)
        hits, nan = bits
        tri = prim_ids < n_tris
        assert nan[:, ~tri].all() and not hits[:, ~tri].any()
        assert not nan[:, tri].any()
        order = prim_ids[tri]
        want = scalar[:, :, order]
        assert np.array_equal(hits[:, tri], want[0] < np.inf)
        got = found[:, :, tri]
        assert np.array_equal(got[:, hits[:, tri]], want[:, hits[:, tri]])
        return hits[:, tri], want[0]

    inf = np.full(len(origins), np.inf)
    hits, t_hit = check(np.zeros(len(origins)), inf)
    # Rays through an edge or a vertex hit every triangle there: some rays
    # hit two or more.
    assert hits.any() and (hits.sum(axis=1) >= 2).any()
    ray, lane = np.nonzero(hits)
    d_hit = t_hit[ray, lane]
    origins, dirs = origins[ray], dirs[ray]
    zero, inf = np.zeros_like(d_hit), np.full_like(d_hit, np.inf)
    for lo, hi, kept in [(zero, d_hit, False), (zero, d_hit * (1 + 1e-9), True),
                         (d_hit, inf, False), (d_hit * (1 - 1e-9), inf, True)]:
        assert np.array_equal(check(lo, hi)[0][np.arange(len(ray)), lane],
                              np.full(len(ray), kept))


@njit
def stack_roundtrip(n):
    a = frame_array(64, np.int64)
    b = frame_array(64, np.float64)
    for i in range(n):
        a[i] = i * i
        b[i] = 0.5 * i
    s = 0.0
    for i in range(n):
        s += a[i] + b[i]
    return s, a.shape[0], b.shape[0]


def test_frame_array():
    assert stack_roundtrip(64) == (sum(i * i + 0.5 * i for i in range(64)), 64, 64)


@njit
def through_window(buffer, first, rows):
    """Rows first .. first + rows - 1 of row_window's view written as
    100 * row + column, and the view's shape."""
    w = row_window(buffer, first, rows)
    for i in range(first, first + rows):
        for a in range(3):
            w[i, a] = 100.0 * i + a
    return w.shape[0], w.shape[1]


@pytest.mark.parametrize("first", [0, 1, 1021, 3 << 30])
def test_row_window_indexes_the_buffer_by_the_call_s_rows(first):
    """Row first of the window is the buffer's first 3 values, the next
    row the next 3 (ray.widen_rays: a chunk of a call's rays in a thread's
    buffer, by the call's row numbers); nothing past the rows is written."""
    buffer = np.full(3 * 5 + 2, -1.0)
    assert through_window(buffer, first, 5) == (first + 5, 3)
    want = [100.0 * (first + k // 3) + k % 3 for k in range(15)] + [-1.0, -1.0]
    assert buffer.tolist() == want


@njit(parallel=True)
def tickets(n_threads, n, clock, taken, by):
    for b in prange(n_threads):
        c = take_ticket(clock)
        while c < n:
            taken[c] += 1
            by[c] = b
            c = take_ticket(clock)


def test_take_ticket_hands_out_each_number_once():
    """Threads racing for tickets: each number below n is taken exactly
    once (a lost update would repeat one), by more than one thread."""
    n = 2_000_000
    clock = np.zeros(1, np.int64)
    taken = np.zeros(n, np.int64)
    by = np.full(n, -1)
    tickets(4, n, clock, taken, by)
    assert np.all(taken == 1)
    assert clock[0] == n + 4       # every thread's last ticket was n or more
    import numba
    if numba.get_num_threads() > 1:
        assert len(np.unique(by)) > 1


@njit(parallel=True)
def row_runs(n_threads, n, clock, taken):
    for b in prange(n_threads):
        size = 1 + b % 3
        s = take_rows(clock, size)
        while s < n:
            for r in range(s, min(s + size, n)):
                taken[r] += 1
            s = take_rows(clock, size)


def test_take_rows_hands_out_runs_that_never_overlap():
    """Threads racing for runs of 1-3 rows from clock[1]: every row below
    n is in exactly one run, and clock[0] (take_ticket's) is untouched."""
    n = 1_000_000
    clock = np.array([7, 0], np.int64)
    taken = np.zeros(n, np.int64)
    row_runs(4, n, clock, taken)
    assert np.all(taken == 1)
    assert clock[0] == 7 and clock[1] >= n
