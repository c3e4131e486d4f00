"""A big mesh's triangle corners, degenerate triangles left out, on every
thread (scene/flatten.py's ``_kept_corners`` for meshes of PARALLEL_MIN faces
and more; smaller ones do not compile this).

The test is flatten.degenerate_mask's, operation for operation, so the two
keep the same triangles bit for bit (tests/test_flatten_corners.py): each
edge's squared length summed x, y, z; the cross product as np.cross forms
it; its length as np.linalg.norm sums it.  Rows whose squared edges lie
outside [1e-140, 1e140] are marked ODD and left to degenerate_mask, which
rescales them.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD

KEPT, DROPPED, ODD = 1, 0, 2


@njit(**dict(BUILD, nogil=True))
def classify(v, corners, ratio, start, end, keep):
    """keep[i] for faces [start, end): KEPT, DROPPED (degenerate) or ODD.
    corners: (3, m) vertex indices, a row per corner."""
    for i in range(start, end):
        a, b, c = corners[0, i], corners[1, i], corners[2, i]
        e1x, e1y, e1z = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
        e2x, e2y, e2z = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
        e3x, e3y, e3z = v[c, 0] - v[b, 0], v[c, 1] - v[b, 1], v[c, 2] - v[b, 2]
        d1 = e1x * e1x + e1y * e1y + e1z * e1z
        d2 = e2x * e2x + e2y * e2y + e2z * e2z
        d3 = e3x * e3x + e3y * e3y + e3z * e3z
        longest2 = max(max(d1, d2), d3)
        if not (longest2 > 1e-140 and longest2 < 1e140):
            keep[i] = ODD
            continue
        cx = e1y * e2z - e1z * e2y
        cy = e1z * e2x - e1x * e2z
        cz = e1x * e2y - e1y * e2x
        area2 = np.sqrt(cx * cx + cy * cy + cz * cz)
        keep[i] = KEPT if area2 > ratio * longest2 else DROPPED


@njit(**dict(BUILD, nogil=True))
def gather(v, corners, keep, start, end, row, v0, v1, v2):
    """The corners of the kept faces among [start, end), into rows row, row
    + 1, ... of v0, v1, v2."""
    for i in range(start, end):
        if keep[i] == KEPT:
            for k in range(3):
                v0[row, k] = v[corners[0, i], k]
                v1[row, k] = v[corners[1, i], k]
                v2[row, k] = v[corners[2, i], k]
            row += 1
