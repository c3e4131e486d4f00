"""The common binary PLY (a vertex element of x, y, z and optionally nx, ny,
nz; a face element of triangles only) read straight into arrays.

This is the layout of scans and of most exported meshes, and reading it
here is several times faster than through trimesh (docs/benchmarks.md,
"Scene").  Anything
else (ASCII, colours, texture coordinates, quads, more elements, a size
that does not add up) returns None and goes to trimesh, which reads every
PLY: what a file means is trimesh's decision for everything but this one
layout, and tests check that both read it alike (tests/test_ply.py).

The format: http://paulbourke.net/dataformats/ply/ (Greg Turk, 1994).
"""
import os

import numpy as np

_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
          "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
          "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
          "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_VERTEX_FIELDS = ({"x", "y", "z"}, {"x", "y", "z", "nx", "ny", "nz"})
_INDEX_NAMES = ("vertex_indices", "vertex_index")
_HEADER_LIMIT = 1 << 16     # bytes: a header longer than this is not the simple layout


def _header(head):
    """(endian, [(element, count, [property words])], data offset) of a
    binary PLY header at the start of ``head``, or None."""
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return None
    stop = head.find(b"\n", end)
    if stop < 0:
        return None
    try:
        lines = [line.split() for line in head[:end].decode("ascii").splitlines()]
    except UnicodeDecodeError:
        return None
    endian = None
    elements = []
    for words in lines[1:]:
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) == 3:
            endian = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(words[1])
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            elements[-1][2].append(words[1:])
        else:
            return None
    return (endian, elements, stop + 1) if endian else None


def read_simple_ply(path):
    """(vertices (n, 3) float64, faces (m, 3) int64, normals (n, 3) float64
    or None) of a PLY file in the simple layout, or None if it is not."""
    with open(path, "rb") as f:
        head = f.read(_HEADER_LIMIT)
    parsed = _header(head)
    if parsed is None:
        return None
    endian, elements, offset = parsed
    if [e[0] for e in elements] != ["vertex", "face"]:
        return None
    (_, n_vertices, vertex_props), (_, n_faces, face_props) = elements
    names = [p[-1] for p in vertex_props]
    if (any(len(p) != 2 or p[0] not in _TYPES for p in vertex_props)
            or len(set(names)) != len(names) or set(names) not in _VERTEX_FIELDS):
        return None
    if (len(face_props) != 1 or len(face_props[0]) != 4 or face_props[0][0] != "list"
            or face_props[0][3] not in _INDEX_NAMES
            or not (_is_integer(face_props[0][1]) and _is_integer(face_props[0][2]))):
        return None
    vertex_type = np.dtype([(name, endian + _TYPES[t]) for t, name in vertex_props])
    # Triangles only: every face is a count of 3 and three indices.
    face_type = np.dtype([("count", endian + _TYPES[face_props[0][1]]),
                          ("index", endian + _TYPES[face_props[0][2]], (3,))])
    need = offset + n_vertices * vertex_type.itemsize + n_faces * face_type.itemsize
    if os.path.getsize(path) != need:
        return None          # quads or mixed polygons, trailing data, or truncated
    vertex_data = np.fromfile(path, vertex_type, n_vertices, offset=offset)
    face_data = np.fromfile(path, face_type, n_faces, offset=offset + vertex_data.nbytes)
    if not (face_data["count"] == 3).all():
        return None
    vertices = _columns(vertex_data, "xyz")
    normals = _columns(vertex_data, ("nx", "ny", "nz")) if "nx" in names else None
    return vertices, face_data["index"].astype(np.int64), normals


def _is_integer(name):
    return _TYPES.get(name, "f")[0] in "iu"


def _columns(records, names):
    """An (n, 3) float64 array of three fields of a record array."""
    out = np.empty((len(records), 3))
    for k, name in enumerate(names):
        out[:, k] = records[name]
    return out
