"""The teapot's big tessellations on every thread (scene/teapot.py's
``tessellate`` from KERNEL_MIN triangles on; smaller ones do not compile
this).

Every value is computed as the NumPy path computes it, operation for
operation and in its order, so both give the same bits
(tests/test_teapot.py): a surface point is 0.0 plus its 16 weighted
control points in turn; a face normal is np.cross's products and
differences; a vertex normal is 0.0 plus its faces' normals in the order
the NumPy path adds them, divided by ((x^2 + y^2) + z^2)'s root.  The
NumPy path's temporaries (the gathered corners, the edges, the unwelded
grid) are never made: at --detail 256 they were hundreds of MB of fresh pages.

Vertices are numbered as the NumPy path's weld leaves them: the n_seam
welded patch-edge vertices first, then each patch's interior grid
vertices, row by row.  A patch's grid is n1 x n1 with n1 = detail + 1;
(x, y) is row x, column y; its quad (x, y) is two triangles, face
2 ((p detail + x) detail + y) + t.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD, BUILD_STEP


@njit(**dict(BUILD, nogil=True))
def interior_points(weight, ctrl, n1, n_seam, first, last, verts):
    """The surface points of patches [first, last)'s interior grid
    vertices into their rows of verts.  weight: (n1 * n1, 16) the
    Bernstein products of each (x, y); ctrl: (16, patches * 3)."""
    m = n1 - 2
    for p in range(first, last):
        for x in range(1, n1 - 1):
            for y in range(1, n1 - 1):
                uv = x * n1 + y
                row = n_seam + (p * m + x - 1) * m + y - 1
                for c in range(3):
                    s = 0.0
                    for ij in range(16):
                        s += weight[uv, ij] * ctrl[ij, 3 * p + c]
                    verts[row, c] = s


@njit(**dict(BUILD, nogil=True))
def grid_faces(welded, n1, first, last, faces):
    """Patches [first, last)'s faces, as vertex numbers: welded[p * n1 * n1
    + x * n1 + y] is grid vertex (x, y) of patch p's number.  Quad (x, y)'s
    corners a (x, y), b (x + 1, y), c (x + 1, y + 1), d (x, y + 1) make
    triangles (a, c, b) and (a, d, c): wound so normals point outwards."""
    detail = n1 - 1
    for p in range(first, last):
        base = p * n1 * n1
        for x in range(detail):
            for y in range(detail):
                a = welded[base + x * n1 + y]
                b = welded[base + (x + 1) * n1 + y]
                c = welded[base + (x + 1) * n1 + y + 1]
                d = welded[base + x * n1 + y + 1]
                f = 2 * ((p * detail + x) * detail + y)
                faces[f, 0], faces[f, 1], faces[f, 2] = a, c, b
                faces[f + 1, 0], faces[f + 1, 1], faces[f + 1, 2] = a, d, c


@njit(**dict(BUILD, nogil=True))
def face_normals(verts, faces, first, last, fn):
    """The unnormalised normals (e1 x e2) of faces [first, last)."""
    for i in range(first, last):
        a, b, c = faces[i, 0], faces[i, 1], faces[i, 2]
        e1x, e1y, e1z = verts[b, 0] - verts[a, 0], verts[b, 1] - verts[a, 1], verts[b, 2] - verts[a, 2]
        e2x, e2y, e2z = verts[c, 0] - verts[a, 0], verts[c, 1] - verts[a, 1], verts[c, 2] - verts[a, 2]
        fn[i, 0] = e1y * e2z - e1z * e2y
        fn[i, 1] = e1z * e2x - e1x * e2z
        fn[i, 2] = e1x * e2y - e1y * e2x


@njit(**BUILD_STEP)
def _unit(x, y, z, normals, row):
    ln = np.sqrt(x * x + y * y + z * z)
    if ln > 0.0:
        normals[row, 0], normals[row, 1], normals[row, 2] = x / ln, y / ln, z / ln
    else:
        normals[row, 0], normals[row, 1], normals[row, 2] = 0.0, 0.0, 0.0


@njit(**BUILD_STEP)
def _six(fn, c, q, q_l, q_u, q_ul):
    """Coordinate c of the sum of an interior vertex's six triangles'
    normals: both of quad (x, y)'s, triangle 0 of (x - 1, y - 1), 1 of
    (x, y - 1), 1 of (x - 1, y - 1) and 0 of (x - 1, y), from 0.0."""
    return (0.0 + fn[q, c] + fn[q + 1, c] + fn[q_ul, c] + fn[q_l + 1, c] + fn[q_ul + 1, c]
            + fn[q_u, c])


@njit(**dict(BUILD, nogil=True))
def interior_normals(fn, n1, n_seam, first, last, normals):
    """Unit normals of patches [first, last)'s interior vertices: each the
    sum of its six triangles' normals, in the NumPy path's order."""
    detail = n1 - 1
    m = n1 - 2
    for p in range(first, last):
        for x in range(1, detail):
            for y in range(1, detail):
                q = 2 * ((p * detail + x) * detail + y)               # quad (x, y)
                q_l = 2 * ((p * detail + x) * detail + y - 1)         # (x, y - 1)
                q_u = 2 * ((p * detail + x - 1) * detail + y)         # (x - 1, y)
                q_ul = 2 * ((p * detail + x - 1) * detail + y - 1)    # (x - 1, y - 1)
                sx = _six(fn, 0, q, q_l, q_u, q_ul)
                sy = _six(fn, 1, q, q_l, q_u, q_ul)
                sz = _six(fn, 2, q, q_l, q_u, q_ul)
                _unit(sx, sy, sz, normals, n_seam + (p * m + x - 1) * m + y - 1)


@njit(**dict(BUILD, nogil=True))
def seam_normals(fn, faces, n_seam, sums, normals):
    """Unit normals of the n_seam welded vertices: each the sum of the
    normals of the faces it is a corner of, corner 0 of every face first,
    then corner 1, then 2 (np.bincount's order in the NumPy path).  sums:
    (n_seam, 3) zeros."""
    for k in range(3):
        for i in range(faces.shape[0]):
            v = faces[i, k]
            if v < n_seam:
                for c in range(3):
                    sums[v, c] += fn[i, c]
    for v in range(n_seam):
        _unit(sums[v, 0], sums[v, 1], sums[v, 2], normals, v)
