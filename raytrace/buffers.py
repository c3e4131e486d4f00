"""Flat structure-of-arrays buffers: the only scene data the kernels see.

One fixed dtype per buffer so each kernel compiles once: float64 geometry
(see README design notes for the measurement), int64 indices.

Primitive ids are unified: ``0 <= p < n_tris`` is triangle p, then spheres,
then planes.  Closest-hit ties are broken by the smaller id, which makes the
result independent of the order a structure visits primitives in.
"""
from collections import namedtuple

import numpy as np

FLOAT = np.float64
INDEX = np.int64

Geometry = namedtuple(
    "Geometry",
    [
        "tri_v0", "tri_v1", "tri_v2",   # (n, 3) vertices
        "tri_n0", "tri_n1", "tri_n2",   # (n, 3) shading normals at the vertices
        "tri_mat",                      # (n,) material index
        "sph_center", "sph_radius", "sph_mat",
        "pl_point", "pl_normal", "pl_mat",
        "mat_color",                    # (q, 3) linear RGB albedo
        "mat_param",                    # (q, N_MAT_PARAMS), see MAT_* below
    ],
)

# Columns of mat_param.
MAT_AMBIENT, MAT_DIFFUSE, MAT_SPECULAR, MAT_SHININESS, MAT_CHECKER = range(5)
N_MAT_PARAMS = 5

Accel = namedtuple(
    "Accel",
    [
        "mode",                         # ACCEL_* below
        # Per-object bounding volumes: object j covers unified primitive ids
        # obj_start[j] .. obj_start[j] + obj_count[j] - 1.
        "obj_lo", "obj_hi", "obj_start", "obj_count",
        # BVH, 4 children per node (accel/bvh.py, collapse_bvh4):
        # node_box (m, 6, 4) child boxes, rows lo x, y, z, hi x, y, z, a lane
        # per child; node_count (m, 4) > 0 makes a lane a leaf covering
        # prim_ids[node_child : node_child + node_count], 0 an inner child,
        # node node_child (or an unused lane, whose box is +inf).
        "node_box", "node_child", "node_count", "prim_ids",
        # Uniform grid: bounds, cell size, resolution (3,), CSR cell lists.
        "grid_lo", "grid_hi", "grid_cell", "grid_res", "cell_start", "cell_items",
    ],
)

ACCEL_NONE, ACCEL_BVOL, ACCEL_BVH, ACCEL_GRID = range(4)
BVH_WIDTH = 4  # children per BVH node: one <4 x double> per box plane (kernels/lowlevel.py)
ACCEL_NAMES = {"none": ACCEL_NONE, "bvol": ACCEL_BVOL, "bvh": ACCEL_BVH, "grid": ACCEL_GRID}


def f64(a, cols=None):
    a = np.ascontiguousarray(a, dtype=FLOAT)
    if cols is not None:
        a = a.reshape(-1, cols)
    return a


def i64(a):
    return np.ascontiguousarray(a, dtype=INDEX).reshape(-1)


def empty_accel(mode):
    """An Accel with every structure empty; builders fill in their part.

    Unused structures are zero-length arrays of the right dtype, so one
    compiled kernel serves every mode and nothing unused is built.
    """
    z3 = np.zeros((0, 3), FLOAT)
    zi = np.zeros(0, INDEX)
    return Accel(
        mode=INDEX(mode),
        obj_lo=z3, obj_hi=z3, obj_start=zi, obj_count=zi,
        node_box=np.zeros((0, 6, BVH_WIDTH), FLOAT), node_child=np.zeros((0, BVH_WIDTH), INDEX),
        node_count=np.zeros((0, BVH_WIDTH), INDEX), prim_ids=zi,
        grid_lo=np.zeros(3, FLOAT), grid_hi=np.zeros(3, FLOAT), grid_cell=np.ones(3, FLOAT),
        grid_res=np.zeros(3, INDEX), cell_start=np.zeros(1, INDEX), cell_items=zi,
    )


def n_bounded(geo):
    """Primitives with a finite box: triangles and spheres (not planes)."""
    return geo.tri_v0.shape[0] + geo.sph_center.shape[0]


def prim_bounds(geo):
    """(lo, hi) boxes of all bounded primitives, indexed by unified id."""
    v = np.stack([geo.tri_v0, geo.tri_v1, geo.tri_v2])
    r = geo.sph_radius[:, None]
    lo = np.concatenate([v.min(axis=0), geo.sph_center - r])
    hi = np.concatenate([v.max(axis=0), geo.sph_center + r])
    return f64(lo, 3), f64(hi, 3)

Lights = namedtuple(
    "Lights",
    [
        "pos",      # (L, 3) centre
        "color",    # (L, 3) colour times intensity
        "u", "v",   # (L, 3) edge vectors of the square area light (zero: point)
        "samples",  # (L,) shadow rays per shading point
        "side",     # (L,) sqrt(samples) for the square patterns
    ],
)
