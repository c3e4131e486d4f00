"""Primitive boxes for the builders, as float32 rows rounded outwards, so each
holds the float64 box it comes from."""
import functools

import numpy as np
from numba import njit

from raytrace.accel.bvh.box8 import HALF, LANES
from raytrace.accel.bvh.f32 import f32_next
from raytrace.accel.bvh.layout import BOX
from raytrace.kernels.buffers import n_bounded
from raytrace.kernels.jit import BUILD, BUILD_STEP
from raytrace.kernels.threads import run_on_threads, runs


@njit(**BUILD_STEP)
def half_area(x0, y0, z0, x1, y1, z1):
    dx = x1 - x0
    dy = y1 - y0
    dz = z1 - z0
    return dx * dy + dy * dz + dz * dx


@njit(**BUILD_STEP)
def round_down(x):
    """The largest float32 at most x (x itself if it is one)."""
    f = np.float32(x)
    if f > x:
        f = f32_next(f, False)
    return f


@njit(**BUILD_STEP)
def round_up(x):
    """The smallest float32 at least x."""
    f = np.float32(x)
    if f < x:
        f = f32_next(f, True)
    return f


def outward(lo, hi):
    """Boxes (lo, hi) as BOX (float32) arrays, rounded outwards, so each
    holds the box it comes from.  The float64 arrays may go once this
    returns: half the bytes through the build."""
    out = []
    for x, away in ((lo, -np.inf), (hi, np.inf)):
        x = np.asarray(x, np.float64).reshape(-1, 3)
        with np.errstate(over="ignore"):    # beyond float32's range: +-inf, still outwards
            y = x.astype(BOX)
        y += BOX(0.0)     # -0.0 is 0.0: NumPy's minimum of the two may give either
        off = y > x if away < 0 else y < x
        y[off] = np.nextafter(y[off], BOX(away))
        out.append(y)
    return out


def box_rows(lo, hi):
    """BOX boxes (lo, hi) (from ``outward``) as the builder's box rows,
    (n, LANES): lo x, y, z, 0, -hi x, y, z, 0 (accel/bvh/box8.py)."""
    lo, hi = np.asarray(lo).reshape(-1, 3), np.asarray(hi).reshape(-1, 3)
    if lo.shape != hi.shape:
        raise ValueError(f"box arrays differ in shape: {lo.shape} vs {hi.shape}")
    rows = np.zeros((len(lo), LANES), BOX)
    rows[:, :3] = lo
    rows[:, HALF:HALF + 3] = -hi
    return rows


@njit(**dict(BUILD, nogil=True))
def box_bounds_kernel(v0, v1, v2, centre, radius, start, end, boxes):
    """Rows [start, end) of ``box_rows(*outward(*prim_bounds(geo)))``
    (unified ids: triangles, then spheres) in one pass, into ``boxes``:
    the float64 boxes are never stored.  nogil, so threads fill disjoint
    rows."""
    n_tris = v0.shape[0]
    for p in range(start, end):
        for a in range(3):
            if p < n_tris:
                low = min(min(v0[p, a], v1[p, a]), v2[p, a])
                high = max(max(v0[p, a], v1[p, a]), v2[p, a])
            else:
                low = centre[p - n_tris, a] - radius[p - n_tris]
                high = centre[p - n_tris, a] + radius[p - n_tris]
            boxes[p, a] = round_down(low) + np.float32(0.0)     # as outward(): no -0.0
            boxes[p, HALF + a] = -(round_up(high) + np.float32(0.0))
        boxes[p, HALF - 1] = 0.0
        boxes[p, LANES - 1] = 0.0


def box_bounds(geo, threads):
    """``box_rows(*outward(*prim_bounds(geo)))`` on ``threads`` threads,
    for big meshes (small ones do not compile it).  At 4.2M triangles the
    two steps took 0.25-0.76 s in one test, this 0.03-0.09 s: 200 MB of
    float64 boxes are never made, nor their pages faulted in."""
    n = n_bounded(geo)
    boxes = np.empty((n, LANES), BOX)
    args = (geo.tri_v0, geo.tri_v1, geo.tri_v2, geo.sph_center, geo.sph_radius)
    run_on_threads([functools.partial(box_bounds_kernel, *args, s, e, boxes)
                    for s, e in runs(n, threads)])
    return boxes


def box_bound(node_box):
    """The largest magnitude of any box coordinate of the tree: the root's
    lanes', since every box holds its children's."""
    if len(node_box) == 0:
        return 0.0
    root = node_box[0]
    return float(np.abs(root[:, root[0] < np.inf]).max(initial=0.0))
