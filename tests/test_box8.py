"""The SAH builder's 8-lane box rows (accel/bvh/box8.py) against the scalar
arithmetic they replace: the same bits, so the same trees."""
import numpy as np
from numba import njit

from raytrace.accel.bvh.box8 import LANES, find_bins, grow_box, grow_centroids
from raytrace.accel.bvh.boxes import box_rows, outward
from raytrace.accel.bvh.layout import BOX

N_BINS = 12


@njit
def _grow_all(rows, boxes):
    """Row 0 grown by every box, row 1 by every centroid (lo + hi)."""
    for p in range(boxes.shape[0]):
        grow_box(rows, 0, boxes, p)
        grow_centroids(rows, 1, boxes, p)


@njit
def _scalar_grow(lo, hi):
    """The scalar builder's loop: min and max of the corners and of the
    centroids 0.5 (lo + hi), Numba's min and max."""
    b = np.full(6, np.inf)
    b[3:] = -np.inf
    c = np.full(6, np.inf)
    c[3:] = -np.inf
    for p in range(lo.shape[0]):
        for a in range(3):
            b[a] = min(b[a], lo[p, a])
            b[3 + a] = max(b[3 + a], hi[p, a])
            x = 0.5 * (lo[p, a] + hi[p, a])
            c[a] = min(c[a], x)
            c[3 + a] = max(c[3 + a], x)
    return b, c


@njit
def _find_all(boxes, origin, scale):
    out = np.empty((boxes.shape[0], 3), np.int8)
    for p in range(boxes.shape[0]):
        find_bins(out, p, boxes, p, origin[0], origin[1], origin[2], scale[0], scale[1], scale[2],
                  N_BINS - 1)
    return out


@njit
def _scalar_bins(lo, hi, origin, scale):
    out = np.empty((lo.shape[0], 3), np.int8)
    for p in range(lo.shape[0]):
        for a in range(3):
            if scale[a] == 0.0:
                out[p, a] = 0
            else:
                out[p, a] = min(int((0.5 * (lo[p, a] + hi[p, a]) - origin[a]) * scale[a]),
                                N_BINS - 1)
    return out


def _awkward_boxes(rng, n):
    """Random boxes with exact zeros (so -hi is -0.0), repeated values and
    coordinates beyond float32's range (+-inf corners, centroids of
    -inf + inf = NaN), as outward() makes them."""
    lo = rng.normal(size=(n, 3))
    lo[: n // 8] = np.round(lo[: n // 8])
    lo[n // 8: n // 4] = 0.0
    hi = lo + rng.random((n, 3))
    hi[n // 8: n // 4] = 0.0
    lo[-3:], hi[-3:] = -1e39, 1e39
    lo[-5:-3, 0], hi[-5:-3, 0] = 1e39, 2e39
    return outward(lo, hi)


def test_grown_rows_are_the_scalar_minima_and_maxima():
    lo, hi = _awkward_boxes(np.random.default_rng(1), 400)
    for n in (len(lo), len(lo) - 5):      # with and without NaN centroids
        rows = np.full((2, LANES), np.inf, BOX)
        _grow_all(rows, box_rows(lo[:n], hi[:n]))
        b, c = _scalar_grow(lo[:n], hi[:n])
        got_b = np.concatenate([rows[0, :3], -rows[0, 4:7]]).astype(np.float64)
        got_c = 0.5 * np.concatenate([rows[1, :3], -rows[1, 4:7]]).astype(np.float64)
        assert np.array_equal(got_b, b) and np.array_equal(got_c, c)
        assert (rows[:, [3, 7]] == 0).all()


def test_bins_are_the_scalar_bins():
    rng = np.random.default_rng(2)
    lo, hi = _awkward_boxes(rng, 400)
    finite = np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1)
    cen = 0.5 * (lo[finite].astype(np.float64) + hi[finite])
    origin = cen.min(axis=0)
    full = N_BINS / (cen.max(axis=0) - origin)
    for scale in (full, np.array([N_BINS / 3.0, 0.0, full[2]])):
        got = _find_all(box_rows(lo[finite], hi[finite]), origin, scale)
        want = _scalar_bins(lo[finite], hi[finite], origin, scale)
        assert np.array_equal(got, want)
        assert got.min() >= 0 and got.max() <= N_BINS - 1
    assert (got[:, 1] == 0).all()       # an axis not binned


def test_bins_of_centroids_beyond_float32_are_defined():
    """A centroid of -inf + inf (NaN) takes bin 0 and one at +inf the last,
    whatever the scale: the conversion is clamped first (LLVM's fptosi of
    NaN or inf is poison).  Finite centroids keep the scalar bins."""
    lo, hi = _awkward_boxes(np.random.default_rng(3), 400)
    finite = np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1)
    cen = 0.5 * (lo[finite].astype(np.float64) + hi[finite])
    origin = cen.min(axis=0)
    scale = N_BINS / (cen.max(axis=0) - origin)
    got = _find_all(box_rows(lo, hi), origin, scale)
    assert np.array_equal(got[finite], _scalar_bins(lo[finite], hi[finite], origin, scale))
    assert (got[-3:] == 0).all()                       # -1e39 .. 1e39: NaN on every axis
    assert (got[-5:-3, 0] == N_BINS - 1).all()         # 1e39 .. 2e39 on x: +inf
    assert got.min() >= 0 and got.max() <= N_BINS - 1
