"""Acceleration structure builds: boxes and centroids in, flat arrays out.

Only the structure a run asks for is built; the others stay empty arrays.
"""
import time

import numpy as np

from ..buffers import (ACCEL_BVH, ACCEL_BVOL, ACCEL_GRID, ACCEL_NAMES, empty_accel, f64, i64,
                       prim_bounds)
from .bvh import build_bvh
from .grid import build_grid


def build_bvol(geo, obj_ranges, acc):
    """One box per object (a mesh's from its vertices, a sphere's from its
    centre and radius), the workshop's Step 3."""
    lo, hi = prim_bounds(geo)
    starts = i64(obj_ranges[:, 0]) if len(obj_ranges) else i64([])
    counts = i64(obj_ranges[:, 1]) if len(obj_ranges) else i64([])
    obj_lo = np.array([lo[s:s + c].min(axis=0) for s, c in zip(starts, counts)]).reshape(-1, 3)
    obj_hi = np.array([hi[s:s + c].max(axis=0) for s, c in zip(starts, counts)]).reshape(-1, 3)
    return acc._replace(obj_lo=f64(obj_lo, 3), obj_hi=f64(obj_hi, 3),
                        obj_start=starts, obj_count=counts)


def build_bvh_accel(geo, acc):
    """Binned-SAH BVH over every bounded primitive (planes have no box and
    are tested separately by every structure)."""
    node_lo, node_hi, node_start, node_count, prim_ids = build_bvh(*prim_bounds(geo))
    return acc._replace(node_lo=node_lo, node_hi=node_hi, node_start=node_start,
                        node_count=node_count, prim_ids=prim_ids)


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
