"""Binary STL read straight into arrays, ASCII STL read by the OBJ
reader's kernel (its "vertex" lines as an OBJ's "v" lines), and any STL's
triangle soup welded: an STL repeats each vertex for every face (3 vertices
a triangle, 72 bytes of float64 positions), and vertices with the same
coordinates, bit for bit, become one.  The facet normals are not read: they
are the faces' own, often zero or stale, and shading computes its own
(normals.py).  An ASCII file of several solids, or in capitals, is
trimesh's to read (scene/formats/mesh.py), then welded here too.

The format: an 80-byte header, a uint32 triangle count, then 50 bytes a
triangle (normal, three vertices, float32 little-endian; a uint16).
"""
import os

import numpy as np

from raytrace.scene.normals import equal_rows

_RECORD = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def read_binary_stl(path):
    """(vertices (n, 3) float64, faces (m, 3) int64) of a binary STL,
    welded, or None if the file is not binary STL (its size does not match
    its count: ASCII, or damaged)."""
    size = os.path.getsize(path)
    if size < 84:
        return None
    count = int(np.fromfile(path, "<u4", 1, offset=80)[0])
    if size != 84 + count * _RECORD.itemsize:
        return None
    corners = np.ascontiguousarray(np.fromfile(path, _RECORD, count, offset=84)["v"])
    corners = corners.reshape(-1, 3)
    # Welded as float32, before the float64 copy: a third of the rows.
    ids, values, _ = equal_rows(corners, values=len(corners) // 6)    # see scene/weld.py
    return values.astype(np.float64), ids.reshape(-1, 3)


def read_ascii_stl(path):
    """(vertices (n, 3) float64, faces (m, 3) int64) of an ASCII STL,
    welded, or None for a file left to trimesh (scene/formats/obj.py)."""
    from raytrace.scene.formats.obj import ascii_stl
    return ascii_stl(path)


def weld(vertices, faces):
    """(vertices, faces) with the vertices of equal coordinates made one
    (each the first of them), in order of first appearance; the faces'
    corners keep their positions bit for bit."""
    ids, values, n = equal_rows(np.ascontiguousarray(vertices, dtype=np.float64))
    if n == len(vertices):
        return vertices, faces
    return values, ids[faces]
