"""Per-object bounding volumes: one box per object (a mesh's from its
vertices, a sphere's from its centre and radius), the workshop's Step 3."""
from collections import namedtuple

import numpy as np

from raytrace.accel.grid.build import grid_eps
from raytrace.kernels.buffers import box_of, f64, i64, prim_bounds

# Object j: box obj_lo[j]..obj_hi[j], covering unified primitive ids
# obj_start[j] .. obj_start[j] + obj_count[j] - 1 (raytrace/accel/bvol/traverse.py).
BoundingVolumes = namedtuple("BoundingVolumes", ["obj_lo", "obj_hi", "obj_start", "obj_count"])


def build(geo, obj_ranges, **_):
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
        # both roundings (the argument is accel/grid/traverse.py's), so the cull
        # is exact for ray origins within ~1e7 scene sizes.
        pad = grid_eps(*box_of(lo, hi))
        obj_lo = obj_lo - pad
        obj_hi = obj_hi + pad
    return BoundingVolumes(obj_lo=f64(obj_lo, 3), obj_hi=f64(obj_hi, 3),
                           obj_start=starts, obj_count=counts)


def empty():
    """A layout of no primitives, of the built ones' types (cast/precompile.py)."""
    z = np.zeros(0, np.int64)
    return BoundingVolumes(obj_lo=np.zeros((0, 3)), obj_hi=np.zeros((0, 3)), obj_start=z,
                           obj_count=z)


def statistics(bvol, n_prims):
    from raytrace.accel.statistics import memory
    return {"boxes": int(len(bvol.obj_lo))} | memory(bvol, n_prims)


def outline(bvol, depth):
    """(lo, hi, level) for --show-structure: each object's box, level 0."""
    return bvol.obj_lo, bvol.obj_hi, np.zeros(len(bvol.obj_lo), np.int64)
