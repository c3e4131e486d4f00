"""Acceleration structure builds: boxes and centroids in, flat arrays out.

Only the structure a run asks for is built; the others stay empty arrays.
"""
import time

import numpy as np

from ..buffers import (ACCEL_BVH, ACCEL_BVOL, ACCEL_GRID, ACCEL_NAMES, empty_accel, f64, i64,
                       prim_bounds)
from .bvh import build_bvh, collapse_bvh4
from .grid import build_grid, grid_eps


def build_bvol(geo, obj_ranges, acc):
    """One box per object (a mesh's from its vertices, a sphere's from its
    centre and radius), the workshop's Step 3."""
    lo, hi = prim_bounds(geo)
    starts = i64(obj_ranges[:, 0]) if len(obj_ranges) else i64([])
    counts = i64(obj_ranges[:, 1]) if len(obj_ranges) else i64([])
    obj_lo = np.array([lo[s:s + c].min(axis=0) for s, c in zip(starts, counts)]).reshape(-1, 3)
    obj_hi = np.array([hi[s:s + c].max(axis=0) for s, c in zip(starts, counts)]).reshape(-1, 3)
    if len(obj_lo):
        # Pad every box by the grid's insertion tolerance (>= 1e-7 of the
        # scene).  A box is culled when its entry distance exceeds the best
        # hit so far, but that entry and the hit distance of a triangle
        # lying on the box's face are rounded differently: unpadded, rays
        # at two coplanar objects took the farther one's hit for ~1% of
        # rays (a few ulps apart), unlike brute force.  The padding dwarfs
        # both roundings (the argument is kernels/grid.py's), so the cull
        # is exact for ray origins within ~1e7 scene sizes.
        pad = grid_eps(lo.min(axis=0), hi.max(axis=0))
        obj_lo = obj_lo - pad
        obj_hi = obj_hi + pad
    return acc._replace(obj_lo=f64(obj_lo, 3), obj_hi=f64(obj_hi, 3),
                        obj_start=starts, obj_count=counts)


def build_bvh_accel(geo, acc):
    """Binned-SAH BVH over every bounded primitive (planes have no box and
    are tested separately by every structure), collapsed to 4 children per
    node for traversal."""
    node_lo, node_hi, node_start, node_count, prim_ids = build_bvh(*prim_bounds(geo))
    node_box, node_child, node_count4 = collapse_bvh4(node_lo, node_hi, node_start, node_count)
    return acc._replace(node_box=node_box, node_child=node_child, node_count=node_count4,
                        prim_ids=prim_ids)


def build_accel(name, geo, obj_ranges):
    """Returns (Accel, build seconds) for structure ``name``."""
    mode = ACCEL_NAMES[name]
    t0 = time.perf_counter()
    acc = empty_accel(mode)
    if mode == ACCEL_BVOL:
        acc = build_bvol(geo, obj_ranges, acc)
    elif mode == ACCEL_BVH:
        acc = build_bvh_accel(geo, acc)
    elif mode == ACCEL_GRID:
        g_lo, g_hi, g_cell, g_res, c_start, c_items = build_grid(*prim_bounds(geo))
        acc = acc._replace(grid_lo=g_lo, grid_hi=g_hi, grid_cell=g_cell, grid_res=g_res,
                           cell_start=c_start, cell_items=c_items)
    return acc, time.perf_counter() - t0
