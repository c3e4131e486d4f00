"""Binary PLY files of the usual layouts read straight into arrays: a
vertex element of scalar properties (x, y, z of any type; optionally nx,
ny, nz; 8-bit red, green, blue; others such as confidence or texture
coordinates without a texture are skipped) and a face element of one index
list (any integer count and index types, either byte order) of triangles
or quads, beside any scalar properties.

These are the layouts of scans and of most exported meshes, read here
several times faster than through trimesh (docs/benchmarks.md, "Scene").
Anything else (ASCII, a texture, face colours, mixed polygons, more
elements, a size that does not add up) returns None and goes to trimesh,
which reads every PLY: what a file means is trimesh's decision for
everything but these layouts, and tests check that both read them alike
(tests/test_ply.py).

The format: http://paulbourke.net/dataformats/ply/ (Greg Turk, 1994).
"""
import os

import numpy as np

_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
          "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
          "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
          "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_INDEX_NAMES = ("vertex_indices", "vertex_index")
_HEADER_LIMIT = 1 << 16     # bytes: a header longer than this is not the simple layout


def _header(head):
    """(format, [(element, count, [property words])], data offset) of a
    PLY header at the start of ``head``, or None; format is "ascii", or
    "<" or ">" for binary little or big endian."""
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
    fmt = None
    elements = []
    for words in lines[1:]:
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) == 3:
            fmt = {"ascii": "ascii", "binary_little_endian": "<",
                   "binary_big_endian": ">"}.get(words[1])
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            elements[-1][2].append(words[1:])
        else:
            return None
    return (fmt, elements, stop + 1) if fmt else None


def read_simple_ply(path):
    """A dict of MeshPart fields (vertices (n, 3) float64, faces (m, 3)
    int64, normals (n, 3) float64 or None, colors (n, 3) linear RGB or
    None) of a binary PLY in a layout read here, or None if it is not."""
    with open(path, "rb") as f:
        head = f.read(_HEADER_LIMIT)
    if b"TextureFile" in head[:head.find(b"end_header")]:
        return None          # a texture and its coordinates: trimesh's reading
    parsed = _header(head)
    if parsed is None or parsed[0] == "ascii":
        return None
    endian, elements, offset = parsed
    if [e[0] for e in elements] != ["vertex", "face"]:
        return None
    (_, n_vertices, vertex_props), (_, n_faces, face_props) = elements
    vertex_type = _scalar_type(vertex_props, endian)
    if vertex_type is None or not {"x", "y", "z"} <= set(vertex_type.names):
        return None
    layout = _face_layout(face_props, endian)
    if layout is None:
        return None
    face_offset = offset + n_vertices * vertex_type.itemsize
    k = _first_count(path, face_offset, layout) if n_faces else 3
    face_type = layout(max(k, 0))
    if (3 <= k <= 4 and os.path.getsize(path) == face_offset + n_faces * face_type.itemsize):
        face_data = np.fromfile(path, face_type, n_faces, offset=face_offset)
        if not (face_data["count"] == k).all():
            return None
        counts, index = None, face_data["index"]
        del face_data
    else:
        counts, index = _polygons(path, face_offset, n_faces, face_props, endian)
        if counts is None:
            return None      # not polygon records that fill the file
    vertex_data = np.fromfile(path, vertex_type, n_vertices, offset=offset)
    names = set(vertex_type.names)
    faces = triangulate(index, counts)
    del index
    colors = None
    if _COLOURS <= names:
        from raytrace.scene.formats.materials import decode_colours
        colors = decode_colours(_columns(vertex_data, _COLOURS_ORDER, np.uint8), linear=False)
    return dict(vertices=_columns(vertex_data, "xyz"), faces=faces,
                normals=_columns(vertex_data, ("nx", "ny", "nz")) if _NORMALS <= names else None,
                colors=colors)


def triangulate(index, counts=None):
    """(m, 3) int64 triangles of polygons: ``index`` (n, k) rows of one size
    (counts None) or all the polygons' indices one after another with
    ``counts``.  Triangles stay triangles; a quad (a, b, c, d) becomes
    (a, b, c) and (c, d, a), every quad's first triangle before any
    second; a larger polygon a fan from its first vertex: trimesh's
    triangulation, in its order, so both read a file alike."""
    if counts is None:
        k = index.shape[1]
        if k == 3:
            return index.astype(np.int64)
        counts, index = np.full(len(index), k), index.reshape(-1)
    starts = np.cumsum(counts) - counts
    out = [index[starts[counts == 3, None] + np.arange(3)]]
    quads = starts[counts == 4, None]
    out += [index[quads + [0, 1, 2]], index[quads + [2, 3, 0]]]
    big = counts > 4
    if big.any():
        # Fan triangle t of a polygon starting at s: (s, s + t + 1, s + t + 2).
        fans = counts[big] - 2
        first = np.repeat(starts[big], fans)
        t = np.arange(len(first)) - np.repeat(np.cumsum(fans) - fans, fans)
        out.append(index[np.stack([first, first + t + 1, first + t + 2], axis=1)])
    return np.concatenate(out).astype(np.int64, copy=False)


def _polygons(path, offset, n_faces, face_props, endian):
    """(counts, indices) of a face element of one index list of polygons
    of any sizes, or (None, None)."""
    if len(face_props) != 1:
        return None, None
    _, count_type, index_type, _ = face_props[0]
    from raytrace.kernels.uncompiled import chosen, file_bytes
    from raytrace.scene.formats.polygons import polygon_lists
    polygon_lists = chosen(polygon_lists, n_faces)       # as Python for a small file
    data = np.fromfile(path, np.uint8, offset=offset)
    count_size, index_size = np.dtype(_TYPES[count_type]).itemsize, np.dtype(_TYPES[index_type]).itemsize
    counts = np.empty(n_faces, np.int64)
    # At most this many indices: every record holds a count and three or more.
    indices = np.empty(max(0, (len(data) - n_faces * count_size) // index_size), np.int64)
    k = polygon_lists(file_bytes(polygon_lists, data), n_faces, count_size, index_size,
                      _TYPES[index_type][0] == "i", endian == ">", counts, indices)
    if k < 0:
        return None, None
    return counts, indices[:k]


_NORMALS = {"nx", "ny", "nz"}
_COLOURS_ORDER = ("red", "green", "blue")
_COLOURS = set(_COLOURS_ORDER)
_FACE_COLOURS = {"red", "green", "blue", "alpha"}


def _scalar_type(props, endian):
    """The record dtype of an element of scalar properties, or None (a list
    property, an unknown type, a repeated name, colours not 8-bit)."""
    names = [p[-1] for p in props]
    if any(len(p) != 2 or p[0] not in _TYPES for p in props) or len(set(names)) != len(names):
        return None
    types = dict((name, t) for t, name in props)
    if _COLOURS <= set(names) and any(_TYPES[types[c]] != "u1" for c in _COLOURS_ORDER):
        return None          # float or 16-bit colours: trimesh's scaling
    return np.dtype([(name, endian + _TYPES[t]) for t, name in props])


def _face_layout(props, endian):
    """A function of k giving the face record dtype for k-gons (fields
    count and index), or None if the face element is not one index list
    among scalar properties (face colours go to trimesh)."""
    lists = [i for i, p in enumerate(props) if p[0] == "list"]
    if len(lists) != 1:
        return None
    (li,) = lists
    lp = props[li]
    if (len(lp) != 4 or lp[3] not in _INDEX_NAMES
            or not (_is_integer(lp[1]) and _is_integer(lp[2]))):
        return None
    scalars = props[:li] + props[li + 1:]
    if _scalar_type(scalars, endian) is None or _FACE_COLOURS & {p[-1] for p in scalars}:
        return None

    def layout(k):
        fields = [(f"_{i}", endian + _TYPES[p[0]]) for i, p in enumerate(props[:li])]
        fields += [("count", endian + _TYPES[lp[1]]), ("index", endian + _TYPES[lp[2]], (k,))]
        fields += [(f"_{li + 1 + i}", endian + _TYPES[p[0]]) for i, p in enumerate(props[li + 1:])]
        return np.dtype(fields)
    return layout


def _first_count(path, offset, layout):
    """The vertex count of the first face record (-1 if none)."""
    t = layout(1)
    first = np.fromfile(path, t, 1, offset=offset)
    return int(first["count"][0]) if len(first) else -1


def _is_integer(name):
    return _TYPES.get(name, "f")[0] in "iu"


def _columns(records, names, dtype=np.float64):
    """An (n, 3) array of three fields of a record array."""
    out = np.empty((len(records), 3), dtype)
    for k, name in enumerate(names):
        out[:, k] = records[name]
    return out


def check_counts(path):
    """Raise for a PLY whose data ends before the elements its header
    declares: trimesh reads what there is of an ASCII file and keeps quiet,
    and refuses a binary one in words that do not say why."""
    from raytrace.errors import RaytraceError
    with open(path, "rb") as f:
        parsed = _header(f.read(_HEADER_LIMIT))
    if parsed is None:
        return
    fmt, elements, offset = parsed
    short = (_ascii_short if fmt == "ascii" else _binary_short)(path, fmt, elements, offset)
    if short:
        raise RaytraceError(f"{path}: the header declares {short}")


def _ascii_short(path, fmt, elements, offset):
    """What an ASCII PLY holds too few of, or None.  One element a line, as
    the format writes them; the lines are counted, not parsed.  A line of
    another length than an element of scalars has ends that element early,
    so a short vertex element is named rather than the faces after it."""
    with open(path, "rb") as f:
        f.seek(offset)
        if sum(1 for line in f if line.strip()) >= sum(count for _, count, _ in elements):
            return None
        f.seek(offset)                 # short: read again to say which element
        words = [len(line.split()) for line in f if line.strip()]
    pos = 0
    for name, count, props in elements:
        n = min(count, len(words) - pos)
        if all(p[0] != "list" for p in props):
            n = next((i for i, w in enumerate(words[pos:pos + n]) if w != len(props)), n)
        if n < count:
            return _ends_after(name, count, n)
        pos += n


def _binary_short(path, endian, elements, offset):
    """What a binary PLY holds too few of, or None.  Records are walked
    while each element's lists are all of one length (else, polygons of
    mixed sizes, only the total is checked); an element is named once at
    least one of its records reads as one, else the file's size is given."""
    size, pos = os.path.getsize(path), offset
    for name, count, props in elements:
        record = _record_type(path, pos, props, endian)
        if record is None:
            break
        n = min(count, (size - pos) // record.itemsize) if record.itemsize else count
        if not _one_length(path, record, pos, n):
            break
        if n < count:
            if n and all(record[f].shape[0] >= 3 for f in record.names if f.startswith("index")):
                return _ends_after(name, count, n)
            break
        pos += n * record.itemsize
    least = [_least_size(props, endian) for _, _, props in elements]
    if None in least:
        return None
    need = sum(count * k for (_, count, _), k in zip(elements, least))
    if size - offset < need:
        declared = " and ".join(f"{count:,} {name}" for name, count, _ in elements)
        return (f"{declared} elements, at least {need:,} bytes; the file holds {size - offset:,} "
                "after its header")
    return None


def _one_length(path, record, pos, n):
    """Whether the n records at ``pos`` hold lists of the lengths of the
    first (as ``record`` takes them)."""
    lists = [f for f in record.names if f.startswith("count")]
    if not (lists and n):
        return True
    records = np.memmap(path, record, "r", offset=pos, shape=(n,))
    return all((records[f] == records[f][0]).all() for f in lists)


def _ends_after(name, count, n):
    return f"{count:,} {name} elements, the file ends after {n:,} of them"


def _record_type(path, pos, props, endian):
    """The dtype of an element's records at ``pos`` if every list in them
    has the length of the first record's, or None (an unknown type, an
    implausible length)."""
    fields = []
    for i, p in enumerate(props):
        if p[0] != "list":
            if len(p) != 2 or p[0] not in _TYPES:
                return None
            fields.append((f"_{i}", endian + _TYPES[p[0]]))
            continue
        if len(p) != 4 or not _is_integer(p[1]) or p[2] not in _TYPES:
            return None
        count_type = endian + _TYPES[p[1]]
        first = np.fromfile(path, np.dtype(fields + [("n", count_type)]), 1, offset=pos)
        k = int(first["n"][0]) if len(first) else 0
        if not 0 <= k <= _HEADER_LIMIT:
            return None
        fields += [(f"count{i}", count_type), (f"index{i}", endian + _TYPES[p[2]], (k,))]
    return np.dtype(fields)


def _least_size(props, endian):
    """The fewest bytes a record of these properties takes: a face's index
    list holds three indices at least, other lists none; None if a type is unknown."""
    total = 0
    for p in props:
        words = p[1:-1] if p[0] == "list" else p[:1]
        if len(p) != (4 if p[0] == "list" else 2) or any(w not in _TYPES for w in words):
            return None
        total += np.dtype(_TYPES[words[0]]).itemsize
        if p[0] == "list" and p[-1] in _INDEX_NAMES:
            total += 3 * np.dtype(_TYPES[words[1]]).itemsize
    return total
