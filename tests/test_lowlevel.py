"""The LLVM-level pieces: ray_aabb4 must answer exactly as ray_aabb does,
lane by lane, since the BVH's bit-identical images rest on it; and the
frame stack array must behave as an ordinary array."""
import numpy as np
import pytest
from numba import njit

from raytrace.accel.bvh import BOX, WIDTH
from raytrace.kernels.bvh import near_rows
from raytrace.kernels.intersect import ray_aabb
from raytrace.kernels.lowlevel import frame_array, ray_aabb4
from raytrace.kernels.ray import make_ray


@njit(error_model="numpy")
def entries_both(node_box, origins, dirs, t_max):
    """(n, m, 4) entry distances from ray_aabb4 and from ray_aabb, for every
    ray against every node's 4 lanes, and ray_aabb4's mask bits."""
    n, m = origins.shape[0], node_box.shape[0]
    simd = np.empty((n, m, WIDTH))
    scalar = np.empty((n, m, WIDTH))
    bits = np.empty((n, m, WIDTH), np.bool_)
    lo = np.empty((WIDTH, 3))
    hi = np.empty((WIDTH, 3))
    for i in range(n):
        ray = make_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                       dirs[i, 0], dirs[i, 1], dirs[i, 2])
        nx, ny, nz = near_rows(ray)
        for node in range(m):
            mask, d = ray_aabb4(node_box, node, nx, ny, nz, ray.ox, ray.oy, ray.oz,
                                ray.inv_x, ray.inv_y, ray.inv_z, t_max[i])
            for j in range(WIDTH):
                simd[i, node, j] = d[j]
                bits[i, node, j] = (mask >> j) & 1
                for a in range(3):
                    lo[j, a] = node_box[node, a, j]
                    hi[j, a] = node_box[node, 3 + a, j]
                scalar[i, node, j] = ray_aabb(ray, lo, hi, j, t_max[i])
    return simd, scalar, bits


def as_nodes(lo, hi):
    """(k, 3) boxes -> (ceil(k/4), 6, 4) node_box, unused lanes +inf, in the
    BVH's box type, rounded outwards as collapse_bvh4 rounds them."""
    m = -(-len(lo) // WIDTH)
    box = np.full((m, 6, WIDTH), np.inf, BOX)
    lo32, hi32 = lo.astype(BOX), hi.astype(BOX)
    lo32 = np.where(lo32 > lo, np.nextafter(lo32, BOX(-np.inf)), lo32)
    hi32 = np.where(hi32 < hi, np.nextafter(hi32, BOX(np.inf)), hi32)
    for k in range(len(lo)):
        box[k // WIDTH, :3, k % WIDTH] = lo32[k]
        box[k // WIDTH, 3:, k % WIDTH] = hi32[k]
    return box


def check(lo, hi, o, d, t_max):
    box = as_nodes(np.asarray(lo, float), np.asarray(hi, float))
    simd, scalar, bits = entries_both(box, np.asarray(o, float), np.asarray(d, float),
                                np.asarray(t_max, float))
    used = ~np.isinf(box[:, 0, :])
    assert np.array_equal(simd[:, used], scalar[:, used])   # same floats, inf alike
    assert np.all(simd[:, ~used] == np.inf)                 # unused lanes never entered
    assert np.array_equal(bits, simd < np.inf)              # the mask names the lanes entered
    return simd[:, used]


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


def test_axis_parallel_rays_on_faces_and_edges():
    """Direction components of +0.0 and -0.0 with the origin in a face plane
    (0 * inf = NaN slab distances): the lane must keep the box exactly when
    ray_aabb does, for every sign of zero."""
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


@pytest.mark.parametrize("offset", [0.0, 1e5])
def test_rays_touching_a_box_edge_keep_it(offset):
    """Ize's widened far bound in the SIMD lanes: rays through a box edge
    (exact: integer directions, o = edge - 3 d) that a textbook slab test
    partly culls (test_extreme.py) are all kept, entering at ~3."""
    rng = np.random.default_rng(8)
    n = 2000
    lo = offset + np.array([-1.0, -2.0, -0.5])
    hi = offset + np.array([1.5, 0.75, 2.0])
    d = rng.integers(1, 1000, (n, 3)).astype(float) * rng.choice([-1.0, 1.0], (n, 3))
    d[:, :2] = np.abs(d[:, :2])
    edge = np.column_stack([np.full(n, hi[0]), np.full(n, lo[1]),
                            lo[2] + rng.integers(1, 10, n) * (hi[2] - lo[2]) / 16])
    o = edge - 3.0 * d
    assert np.array_equal(o + 3.0 * d, edge)
    e = check(np.tile(lo, (4, 1)), np.tile(hi, (4, 1)), o, d, np.full(n, np.inf))
    assert np.all(np.abs(e - 3.0) <= 1e-12 * max(1.0, offset))


def test_t_max_and_behind():
    """Entry beyond t_max, or a box wholly behind the origin: a miss; an
    origin inside: entry 0; t_max exactly at the entry: kept (inclusive)."""
    lo, hi = np.array([[1.0, -1, -1]]), np.array([[2.0, 1, 1]])
    o = np.array([[0.0, 0, 0], [0.0, 0, 0], [3.0, 0, 0], [1.5, 0, 0], [0.0, 0, 0]])
    d = np.array([[1.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    t_max = np.array([np.inf, 0.5, np.inf, np.inf, np.inf])
    e = check(lo, hi, o, d, t_max)[:, 0]
    assert e.tolist() == [1.0, np.inf, np.inf, 0.0, np.inf]
    e = check(lo, hi, o[:1], d[:1], np.array([1.0]))[:, 0]
    assert e.tolist() == [1.0]


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
