"""Closest hits' fields in Open3D's dtypes, in one pass over the hit
records: float32 t, uv and unit normal, uint32 geometry and face ids (a
miss: t inf, ids INVALID_ID, uv and normal 0), for the Open3D drop-in
(cast/open3d_scene.py).  NumPy made them field by field (the ids, the
uvs, normals and points in float64, then a cast and a masked copy of
each), several passes over every ray where this is one over the hits;
docs/benchmarks.md, "Drop-ins", has the numbers.

The normal is cast/prepared.py's ``surface`` normal, the same arithmetic
in the same order, so the same bits: the cross product of the edges
(flatten.cross_rows), scaled to unit length as flatten.unit_rows scales
it (a tiny or huge one first divided by its largest component).
"""
import functools

import numpy as np
from numba import njit

from raytrace.kernels.jit import BLOCK
from raytrace.kernels.threads import run_on_threads, runs
from raytrace.kernels.vector import unit3

INVALID_ID = 2 ** 32 - 1


@njit(**BLOCK)
def _fields_block(hits, prim_object, prim_face, triangles, start, end, outs):
    """Rays start:end: a thread's share of hit_fields (hits: prim, t, u, v;
    triangles: tri_v0, tri_v1, tri_v2; outs: hit_fields' five arrays)."""
    prim, t, u, v = hits
    tri_v0, tri_v1, tri_v2 = triangles
    out_t, out_geometry, out_prim, out_uv, out_normal = outs
    for i in range(start, end):
        p = prim[i]
        out_t[i] = t[i]
        if p < 0:
            out_geometry[i] = INVALID_ID
            out_prim[i] = INVALID_ID
            for k in range(2):
                out_uv[i, k] = 0.0
            for k in range(3):
                out_normal[i, k] = 0.0
            continue
        out_geometry[i] = prim_object[p]
        out_prim[i] = prim_face[p]
        out_uv[i, 0] = u[i]
        out_uv[i, 1] = v[i]
        e1x, e1y, e1z = (tri_v1[p, 0] - tri_v0[p, 0], tri_v1[p, 1] - tri_v0[p, 1],
                         tri_v1[p, 2] - tri_v0[p, 2])
        e2x, e2y, e2z = (tri_v2[p, 0] - tri_v0[p, 0], tri_v2[p, 1] - tri_v0[p, 1],
                         tri_v2[p, 2] - tri_v0[p, 2])
        nx, ny, nz = unit3(e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x)
        out_normal[i, 0] = nx
        out_normal[i, 1] = ny
        out_normal[i, 2] = nz


def hit_fields(prim, t, u, v, prim_object, prim_face, tri_v0, tri_v1, tri_v2, threads):
    """(t, geometry_id, prim_id, uv (n, 2), normal (n, 3)) of n closest
    hits (the kernel's unified primitive ids ``prim``, -1 a miss, all of
    them triangles; t, u, v as cast_closest writes them), float32 and
    uint32, computed on ``threads`` threads."""
    n = len(prim)
    out = (np.empty(n, np.float32), np.empty(n, np.uint32), np.empty(n, np.uint32),
           np.empty((n, 2), np.float32), np.empty((n, 3), np.float32))
    hits, triangles = (prim, t, u, v), (tri_v0, tri_v1, tri_v2)
    run_on_threads([functools.partial(_fields_block, hits, prim_object, prim_face, triangles, s, e,
                                      out) for s, e in runs(n, threads)])
    return out
