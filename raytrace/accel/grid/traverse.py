"""Uniform grid traversal by 3D-DDA (Amanatides & Woo 1987, "A Fast Voxel
Traversal Algorithm for Ray Tracing"): clip the ray to the grid, find the
start cell, then repeatedly step into the neighbour across whichever cell
face the ray crosses first.

Why the answer equals brute force bit for bit
---------------------------------------------
Primitive tests are the same calls as brute force's (``test_prim`` with the
ray's own t_max) and hits merge with ``closer`` (distance, then smaller
id), so the grid's answer is brute force's as soon as the brute-force winner
p* (hit distance t*) is among the primitives tested.  A primitive spanning
several cells may be hit outside the cell being visited, so we keep the best
hit over everything tested and only stop once the next cell starts beyond
it.  Two kinds of rounding could still make us miss p*:

1. Where the DDA thinks the ray is.  The crossing distances are rounded and
   the start cell comes from a rounded point, so near a cell face (or an
   edge or corner, where the order of two crossings can flip) the DDA may
   assign the ray's points to a neighbouring cell.  Each crossing is
   recomputed from its face's coordinate (never accumulated), so along
   each axis the error is a few ulps of the coordinates and of the ray's
   travel: the cell the DDA assigns to any t on the walk is within
   ~10 ulps of max(|origin|, |grid coordinates|) of the true point o + t d.
2. Where the hit is.  The computed t* is rounded too, so o + t* d can lie a
   few ulps outside p*'s box (the watertight test's t is accurate to a few
   ulps unless the ray is within ~1e-9 rad of the triangle's plane).

Conservative insertion absorbs both: the build lists each primitive in
every cell its box *widened by grid_eps* overlaps (accel/grid/build.py;
grid_eps >= 1e-7 of the scene, far above both errors).  So the cell the DDA
assigns to t* lists p*.  The cells are visited in order of their t-ranges,
and we stop only after a cell whose computed exit distance exceeds
min(best_t, t_max) >= t*, so that cell was visited and p* tested.  The
comparison is against the same computed crossings that define the cells'
t-ranges, so no t margin is needed for the argument; STOP_SCALE adds a
2^-32 relative one anyway, which costs an extra cell only for hits within
2^-32 of a face.  Occlusion is the same argument with t* the distance of
any occluder.

The error bound in (1) grows with the distance of the ray origin, so rays
starting more than ~1e6 scene sizes away (or with NaN/inf/subnormal
components) skip the DDA and test every primitive: still brute force's
answer, just slow.  Not covered: a ray lying exactly in a triangle's plane,
where the watertight test's verdict is itself rounding noise and may report
a "hit" anywhere along the triangle's extent.
"""
import numpy as np
from numba import njit

from raytrace.accel.brute.traverse import SCANS
from raytrace.accel.grid.build import Grid, grid_eps
from raytrace.kernels.counters import BOX_TESTS, CELLS_VISITED
from raytrace.kernels.intersect import ray_aabb
from raytrace.kernels.jit import JIT
from raytrace.kernels.prims import test_and_keep
from raytrace.kernels.query import ALL_HITS, ANY_HIT, CLOSEST, register
from raytrace.kernels.ray import no_hit

# Keep stepping until the next cell starts beyond best_t by this relative
# margin (see the module docstring: belt and braces, ~free).
STOP_SCALE = 1.0 - 2.0 ** -32
# Rays are walked only if GUARD_ULPS ulps of their origin's and the grid's
# largest coordinate stay within grid_eps: 1024 is ~100x the DDA's and the
# hit point's rounding (~10 ulps), and with grid_eps >= 1e-7 of the scene it
# admits every origin within ~1e6 scene sizes.
GUARD_ULPS = 1024.0
_U = 2.0 ** -53

_MISS, _WALK, _ALL = 0, 1, 2


@njit(**JIT)
def _crossing(o, inv, glo, cell, i, step):
    """Distance at which the ray leaves cell i through its face on this
    axis, from the face's coordinate (not accumulated, so the error does not
    grow with the number of steps)."""
    k = i + 1 if step > 0 else i
    return (glo + k * cell - o) * inv


@njit(**JIT)
def _axis_start(o, d, inv, t0, glo, cell, res):
    """Start cell index, step and first face crossing along one axis.

    An axis with d == 0.0 or -0.0 (inverse +-inf) is never stepped: its
    crossing is inf, not the NaN that 0 * inf would give on a face.
    """
    f = ((o + t0 * d) - glo) / cell
    if f >= 0.0:
        i = int(f) if f < res else res - 1
    else:
        i = 0
    if d == 0.0:
        return i, 0, np.inf
    step = 1 if d > 0.0 else -1
    return i, step, _crossing(o, inv, glo, cell, i, step)


@njit(**JIT)
def _grid_enter(acc, ray, t_max, cnt):
    """Clip the ray to the grid and set up the DDA.

    Returns (status, ix, iy, iz, sx, sy, sz, tx, ty, tz): _MISS (nothing to
    do), _ALL (test every primitive, see GUARD_ULPS) or _WALK with the start
    cell, the steps and the first crossing along each axis.
    """
    if acc.cell_items.shape[0] == 0:
        return _MISS, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0
    glo = acc.grid_lo
    ghi = acc.grid_hi
    cnt[BOX_TESTS] += 1
    t0 = ray_aabb(ray, glo.reshape(1, 3), ghi.reshape(1, 3), np.int64(0), t_max)   # not a literal
    if t0 == np.inf:
        return _MISS, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0
    mag = max(abs(ray.ox), abs(ray.oy), abs(ray.oz),
              abs(glo[0]), abs(glo[1]), abs(glo[2]),
              abs(ghi[0]), abs(ghi[1]), abs(ghi[2]))
    # Written so that NaN fails every test.  A subnormal direction component
    # has an infinite inverse although the ray does move along that axis.
    walk = (GUARD_ULPS * _U * mag <= grid_eps(glo, ghi)
            and (ray.dx == 0.0 or abs(ray.inv_x) < np.inf)
            and (ray.dy == 0.0 or abs(ray.inv_y) < np.inf)
            and (ray.dz == 0.0 or abs(ray.inv_z) < np.inf))
    if not walk:
        return _ALL, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0
    cell = acc.grid_cell
    res = acc.grid_res
    ix, sx, tx = _axis_start(ray.ox, ray.dx, ray.inv_x, t0, glo[0], cell[0], res[0])
    iy, sy, ty = _axis_start(ray.oy, ray.dy, ray.inv_y, t0, glo[1], cell[1], res[1])
    iz, sz, tz = _axis_start(ray.oz, ray.dz, ray.inv_z, t0, glo[2], cell[2], res[2])
    return _WALK, ix, iy, iz, sx, sy, sz, tx, ty, tz


@njit(**JIT)
def _dda_step(ray, glo, cell, res, cell_index, step, t_next, t_stop):
    """Step into the neighbour across the nearest face, unless the next cell
    starts beyond t_stop or the ray leaves the grid: res, the cell's index,
    the walk's step (+-1) and the distance to the next cell boundary are
    (x, y, z) tuples.

    Returns (inside, ix, iy, iz, tx, ty, tz); inside False ends the walk.
    """
    rx, ry, rz = res
    ix, iy, iz = cell_index
    sx, sy, sz = step
    tx, ty, tz = t_next
    t_exit = min(tx, ty, tz)
    inside = True
    if t_exit == np.inf or t_exit * STOP_SCALE > t_stop:
        inside = False
    elif tx == t_exit:
        ix += sx
        inside = 0 <= ix < rx
        tx = _crossing(ray.ox, ray.inv_x, glo[0], cell[0], ix, sx)
    elif ty == t_exit:
        iy += sy
        inside = 0 <= iy < ry
        ty = _crossing(ray.oy, ray.inv_y, glo[1], cell[1], iy, sy)
    else:
        iz += sz
        inside = 0 <= iz < rz
        tz = _crossing(ray.oz, ray.inv_z, glo[2], cell[2], iz, sz)
    return inside, ix, iy, iz, tx, ty, tz


def _traversal(mode):
    """The DDA walk, for one of query.py's modes (a compile-time constant).
    Until a hit is kept best.t is inf, so the walk is bounded by t_max.

    Every hit (ALL_HITS) scans all primitives instead: a primitive lies in
    every cell its box overlaps, and the mailbox remembers only the last
    four, so a walk could count one twice."""
    scan = SCANS[mode]

    @njit(**JIT)
    def traverse(geo, acc, ray, t_max, cnt):
        best = no_hit()
        status, ix, iy, iz, sx, sy, sz, tx, ty, tz = _grid_enter(acc, ray, t_max, cnt)
        if status == _MISS:
            return best
        if status == _ALL or mode == ALL_HITS:
            return scan(geo, ray, t_max, cnt)
        rx, ry, rz = acc.grid_res[0], acc.grid_res[1], acc.grid_res[2]
        glo, cell = acc.grid_lo, acc.grid_cell
        cell_start, cell_items = acc.cell_start, acc.cell_items
        # Mailbox: the last four primitives tested.  A triangle spanning
        # neighbouring cells is tested once; a retest would give the same
        # (t, id), which `closer` rejects, so skipping it changes nothing.
        m0 = m1 = m2 = m3 = -1
        inside = True
        while inside and not (mode == ANY_HIT and best.prim >= 0):
            cnt[CELLS_VISITED] += 1
            c = ix + rx * (iy + ry * iz)
            k = cell_start[c]
            end = cell_start[c + 1]
            while k < end and not (mode == ANY_HIT and best.prim >= 0):
                p = cell_items[k]
                if p != m0 and p != m1 and p != m2 and p != m3:
                    m3, m2, m1, m0 = m2, m1, m0, p
                    best = test_and_keep(geo, ray, p, t_max, best, cnt, mode != ALL_HITS)
                k += 1
            inside, ix, iy, iz, tx, ty, tz = _dda_step(ray, glo, cell, (rx, ry, rz), (ix, iy, iz),
                                                       (sx, sy, sz), (tx, ty, tz),
                                                       min(best.t, t_max))
        return best
    return traverse


register(Grid, *(_traversal(mode) for mode in (CLOSEST, ANY_HIT, ALL_HITS)))
