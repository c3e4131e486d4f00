"""Flat structure-of-arrays buffers: the only scene data the kernels see.

One fixed dtype per buffer so each kernel compiles once: float64 geometry
(docs/design.md, "Precision"), int64 indices.  Each acceleration structure's own layout
lives beside its builder (raytrace/accel/).

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
        # Shading normals, unit: vtx_normal (k, 3) once per vertex, and each
        # triangle's corners' rows of it, tri_normal (n, 3) int32 (36 bytes a
        # triangle less than three (n, 3) arrays; read only when shading).
        "vtx_normal", "tri_normal",
        "tri_mat",                      # (n,) material index
        # Per vertex: linear RGB multiplying the material's colour (k, 3)
        # and texture coordinates (k, 2), empty (0, 3) and (0, 2) when no
        # mesh has them (kernels/texture.py); each triangle's corners' rows
        # of them, tri_vertex (n, 3) int32, is tri_normal itself where the
        # normals are the vertices' own (a file's PLY): 72 bytes a triangle
        # of corner colours were a 4.2M-triangle file's 300 MB.  Few, larger
        # arrays: every array in this record is an argument of every kernel
        # function that takes it.
        "tri_vertex", "vtx_color", "vtx_uv",
        "sph_center", "sph_radius", "sph_mat",
        "pl_point", "pl_normal", "pl_mat",
        "mat_color",                    # (q, 3) linear RGB albedo
        "mat_param",                    # (q, N_MAT_PARAMS), see MAT_* below
        "mat_tex",                      # (q, 3) its texture's offset, width, height (0: none)
        "tex_rgb",                      # (texels, 3) float32 linear RGB of every texture
    ],
)

# Columns of mat_param.
(MAT_AMBIENT, MAT_DIFFUSE, MAT_SPECULAR, MAT_SHININESS, MAT_CHECKER, MAT_REFLECT, MAT_TRANSMIT,
 MAT_IOR, MAT_EMISSION) = range(9)
# MAT_EMISSION .. MAT_EMISSION + 2: emitted RGB radiance (the path tracer's);
# MAT_GLOSSY: the path tracer's glossy weight (kernels/glossy.py).
MAT_GLOSSY = 11
N_MAT_PARAMS = 12

def f64(a, cols=None):
    a = np.ascontiguousarray(a, dtype=FLOAT)
    if cols is not None:
        a = a.reshape(-1, cols)
    return a


def i64(a):
    return np.ascontiguousarray(a, dtype=INDEX).reshape(-1)


def n_bounded(geo):
    """Primitives with a finite box: triangles and spheres (not planes)."""
    return geo.tri_v0.shape[0] + geo.sph_center.shape[0]


def prim_bounds(geo):
    """(lo, hi) boxes of all bounded primitives, indexed by unified id."""
    # Pairwise minima and maxima into the result: no stacked copy of the
    # three corners, and no temporary (fresh memory costs its page faults).
    lo = np.minimum(geo.tri_v0, geo.tri_v1)
    np.minimum(lo, geo.tri_v2, out=lo)
    hi = np.maximum(geo.tri_v0, geo.tri_v1)
    np.maximum(hi, geo.tri_v2, out=hi)
    if len(geo.sph_radius):
        r = geo.sph_radius[:, None]
        lo = np.concatenate([lo, geo.sph_center - r])
        hi = np.concatenate([hi, geo.sph_center + r])
    return f64(lo, 3), f64(hi, 3)


def box_of(lo, hi):
    """The box around (n > 0, 3) boxes lo, hi: each column's minimum of lo
    and maximum of hi, a column at a time.  NumPy's min(axis=0) over an
    (n, 3) array reduces three values at a time, several times slower.  The
    same values either way."""
    return (np.array([lo[:, k].min() for k in range(3)]),
            np.array([hi[:, k].max() for k in range(3)]))


Lights = namedtuple(
    "Lights",
    [
        "pos",      # (L, 3) centre
        "color",    # (L, 3) colour times intensity
        "u", "v",   # (L, 3) edge vectors of the square area light (zero: point)
        "samples",  # (L,) shadow rays per shading point
        "side",     # (L,) sqrt(samples) for the square patterns
        "hashes",   # (2 max(samples),) uint64: sampling.sample_hashes
    ],
)
