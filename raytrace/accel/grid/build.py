"""Uniform grid build: primitive boxes in, CSR cell lists out.

The grid covers the union of the primitive boxes, padded.  Cell (x, y, z)
has index ``x + res_x * (y + res_y * z)`` and lists the unified ids
``cell_items[cell_start[c] : cell_start[c + 1]]`` of every primitive whose
box, widened by the tolerance ``grid_eps``, overlaps the closed cell.  That
widening is what lets the traversal (accel/grid/traverse.py) return exactly the
brute-force answer despite rounding; the argument is written out there.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.kernels.buffers import FLOAT, INDEX, box_of, prim_bounds
from raytrace.kernels.jit import BUILD, BUILD_STEP

# The layout traversal reads (raytrace/accel/grid/traverse.py): bounds, cell size
# and resolution (3,), and CSR cell lists.  ``grid_eps`` below is part of
# the contract: traversal recomputes it from the stored bounds.
Grid = namedtuple("Grid", ["grid_lo", "grid_hi", "grid_cell", "grid_res", "cell_start",
                           "cell_items"])

# Cells along the longest axis per cube root of the primitive count: about
# 27 cells per primitive for a cubic scene (pbrt-v2's GridAccel uses the
# same 3 * cbrt(N)).
GRID_DENSITY = 3.0
# Per-axis cap: 128^3 = 2.1M cells = 17 MB of int64 cell_start; it binds
# only above ~80k primitives, where memory matters more than cell size.
GRID_MAX_RES = 128

# Tolerance used to widen every primitive box before insertion, as a
# fraction of the scene's size plus a fraction of its largest coordinate.
# It must exceed the rounding of the DDA and of hit points (at most ~1e3
# ulps of the coordinates, see accel/grid/traverse.py); 1e-7 of the scene is 4e-5
# of a cell at the maximum resolution, so it adds almost no list entries,
# and 1e-11 of the magnitude is ~1e5 ulps for scenes far from the origin.
GRID_EPS_EXTENT = 1e-7
GRID_EPS_MAGNITUDE = 1e-11


@njit(**BUILD)
def grid_eps(glo, ghi):
    """Insertion tolerance of a grid with bounds glo, ghi (shape (3,)).

    A pure function of the stored bounds, so the build and the traversal's
    far-origin guard compute the same value bit for bit.
    """
    ext = 0.0
    mag = 0.0
    for a in range(3):
        ext = max(ext, ghi[a] - glo[a])
        mag = max(mag, abs(glo[a]), abs(ghi[a]))
    eps = GRID_EPS_EXTENT * ext + GRID_EPS_MAGNITUDE * mag
    if eps == 0.0:  # every box is the single point 0: any positive size works
        eps = GRID_EPS_EXTENT
    return eps


@njit(**BUILD_STEP)
def _cell_range(lo, hi, glo, cell, res, eps):
    """First and last cell index along one axis touched by [lo - eps, hi + eps]."""
    f0 = (lo - eps - glo) / cell
    f1 = (hi + eps - glo) / cell
    # floor, clamped in float first so far-out values never overflow int64.
    i0 = 0 if f0 < 0.0 else (res - 1 if f0 >= res else int(np.floor(f0)))
    i1 = 0 if f1 < 0.0 else (res - 1 if f1 >= res else int(np.floor(f1)))
    return i0, i1


@njit(**BUILD_STEP)
def _cell_box(lo, hi, p, glo, cell, res, eps):
    """Cell index ranges (x0, x1, y0, y1, z0, z1) of primitive p's widened box."""
    x0, x1 = _cell_range(lo[p, 0], hi[p, 0], glo[0], cell[0], res[0], eps)
    y0, y1 = _cell_range(lo[p, 1], hi[p, 1], glo[1], cell[1], res[1], eps)
    z0, z1 = _cell_range(lo[p, 2], hi[p, 2], glo[2], cell[2], res[2], eps)
    return x0, x1, y0, y1, z0, z1


@njit(**BUILD)
def _fill_cells(lo, hi, glo, cell, res, eps):
    """Two passes over the boxes: count entries per cell, then fill the CSR
    lists (ids ascending within each cell, since p runs in order)."""
    rx, ry = res[0], res[1]
    n_cells = res[0] * res[1] * res[2]
    cell_start = np.zeros(n_cells + 1, np.int64)
    for p in range(lo.shape[0]):
        x0, x1, y0, y1, z0, z1 = _cell_box(lo, hi, p, glo, cell, res, eps)
        for z in range(z0, z1 + 1):
            for y in range(y0, y1 + 1):
                for x in range(x0, x1 + 1):
                    cell_start[x + rx * (y + ry * z) + 1] += 1
    for c in range(n_cells):
        cell_start[c + 1] += cell_start[c]
    cell_items = np.empty(cell_start[n_cells], np.int64)
    cursor = cell_start[:n_cells].copy()
    for p in range(lo.shape[0]):
        x0, x1, y0, y1, z0, z1 = _cell_box(lo, hi, p, glo, cell, res, eps)
        for z in range(z0, z1 + 1):
            for y in range(y0, y1 + 1):
                for x in range(x0, x1 + 1):
                    c = x + rx * (y + ry * z)
                    cell_items[cursor[c]] = p
                    cursor[c] += 1
    return cell_start, cell_items


def grid_resolution(ext, n, density=GRID_DENSITY):
    """Cells per axis: density * cbrt(n) along the longest axis, the others
    proportional to their extent, each in [1, GRID_MAX_RES]."""
    longest = density * np.cbrt(n)
    res = np.rint(longest * ext / ext.max())
    return np.clip(res, 1, GRID_MAX_RES).astype(INDEX)


def build_grid(lo, hi, density=GRID_DENSITY):
    """Uniform grid over (n, 3) primitive boxes lo, hi (row = unified id).

    Returns (grid_lo, grid_hi, grid_cell, grid_res, cell_start, cell_items).
    With n == 0 the grid has resolution (0, 0, 0) and no cells, so the
    traversal does nothing.
    """
    lo = np.ascontiguousarray(lo, dtype=FLOAT).reshape(-1, 3)
    hi = np.ascontiguousarray(hi, dtype=FLOAT).reshape(-1, 3)
    n = lo.shape[0]
    if n == 0:
        return (np.zeros(3, FLOAT), np.zeros(3, FLOAT), np.ones(3, FLOAT),
                np.zeros(3, INDEX), np.zeros(1, INDEX), np.zeros(0, INDEX))
    raw_lo, raw_hi = box_of(lo, hi)
    # Pad by twice the tolerance: boundary primitives (and their widened
    # boxes) lie strictly inside, and a flat axis (every box in one plane)
    # still gets a cell of positive size.
    pad = 2.0 * grid_eps(raw_lo, raw_hi)
    grid_lo = raw_lo - pad
    grid_hi = raw_hi + pad
    res = grid_resolution(grid_hi - grid_lo, n, density)
    cell = (grid_hi - grid_lo) / res
    eps = grid_eps(grid_lo, grid_hi)
    cell_start, cell_items = _fill_cells(lo, hi, grid_lo, cell, res, eps)
    return grid_lo, grid_hi, cell, res, cell_start, cell_items


def build(geo, obj_ranges, grid_density=GRID_DENSITY, **_):
    return Grid(*build_grid(*prim_bounds(geo), density=grid_density))


def empty():
    """A layout of no primitives, of the built ones' types (cast/precompile.py)."""
    z = np.zeros(3)
    return Grid(z, z, z, np.ones(3, np.int64), np.zeros(2, np.int64), np.zeros(0, np.int64))


def statistics(grid, n_prims):
    """Resolution, cells, empty cells, references and memory of a grid."""
    from raytrace.accel.statistics import memory
    cells = int(np.prod(grid.grid_res))
    per_cell = np.diff(grid.cell_start)
    refs = int(len(grid.cell_items))
    return {"resolution": [int(r) for r in grid.grid_res], "cells": cells,
            "empty_cells": int((per_cell == 0).sum()),
            "cells_per_primitive": cells / n_prims if n_prims else 0.0,
            "references": refs, "references_per_primitive": refs / n_prims if n_prims else 0.0,
            } | memory(grid, n_prims)


def outline(grid, depth):
    """(lo, hi, level) for --show-structure: the grid's bounds (level 0),
    then, from depth 1, every cell that holds a primitive (level 1)."""
    lo, hi = [np.asarray(grid.grid_lo, float)], [np.asarray(grid.grid_hi, float)]
    levels = [0]
    if depth >= 1:
        nx, ny, nz = (int(n) for n in grid.grid_res)
        full = np.flatnonzero(np.diff(grid.cell_start) > 0)
        # Cell index x + nx * (y + ny * z), as the builder numbers them.
        ijk = np.stack([full % nx, full // nx % ny, full // (nx * ny)], axis=1)
        cell_lo = grid.grid_lo + ijk * grid.grid_cell
        lo.extend(cell_lo)
        hi.extend(cell_lo + grid.grid_cell)
        levels.extend([1] * len(full))
    return np.array(lo).reshape(-1, 3), np.array(hi).reshape(-1, 3), np.array(levels, np.int64)
