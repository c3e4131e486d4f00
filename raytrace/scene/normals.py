"""Per-vertex shading normals for a triangle mesh: smooth across gentle
edges, split at creases.

Each face normal is weighted by the face's angle at the vertex (Thürmer &
Wüthrich 1998, "Computing vertex normals from polygonal facets"): unlike
area weights, the result does not change when a face is cut into more
triangles.  A vertex whose faces meet at a crease gets one copy per smooth
group -- the faces around it joined through edges whose face normals
differ by at most the crease angle -- so the normals array stays per
vertex, as the renderer wants.  Copies repeat the position bit for bit:
the triangles, and every hit, are unchanged.

The split is a map from input vertices (``crease_split``'s ``source``), so
colours and texture coordinates follow it as the positions do.  The fans
are grouped in a small kernel (scene/creases.py), one vertex position at
a time on every thread, in memory linear in the mesh (docs/design.md).
"""
import math

import numpy as np

from raytrace.options import CREASE
from raytrace.scene.flatten import cross_rows, unit_rows

DEFAULT_CREASE = CREASE.default   # degrees; why 35: docs/design.md, "The scene"


def face_normals(vertices, faces):
    """Unit normal of each face by its winding; zero for a degenerate face."""
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    return unit_rows(cross_rows(v1 - v0, v2 - v0))


def face_frames(vertices, faces):
    """(unit normals (m, 3), corner angles (m, 3) in radians) of the faces,
    from the kernel (creases.face_frame) on threads.  One way for every
    caller: NumPy's arctan2 is not libm's on every machine (its AVX-512
    code differs in the last bit), so angles made by both would not agree."""
    from raytrace.kernels.uncompiled import chosen
    from raytrace.scene.creases import face_frames as frames_kernel
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    m = len(f)
    frames_kernel = chosen(frames_kernel, 3 * m)
    fn, angles = np.empty((m, 3)), np.empty((m, 3))
    _on_threads(frames_kernel, [(v, f, a, b, fn, angles) for a, b in _face_runs(m)])
    return fn, angles


def crease_normals(vertices, faces, crease=DEFAULT_CREASE):
    """(vertices, faces, normals) with smooth normals split at creases.

    Faces whose normals differ by more than ``crease`` degrees do not share
    a normal at their common edge's vertices; such a vertex is copied once
    per smooth group, so a cube's faces use 24 vertices and 6 normals and
    a sphere keeps its vertices.  A group whose weighted normals cancel takes
    one of its faces' normals.
    """
    v = np.asarray(vertices, dtype=np.float64)
    source, f, normals = crease_split(v, faces, crease)
    return v[source], f, normals


def crease_split(vertices, faces, crease=DEFAULT_CREASE, keep=False, welded=False):
    """(source, faces, normals): crease_normals's mesh as a map from input
    vertices, so that every per-vertex array follows the split: output
    vertex i copies input vertex ``source[i]`` (its position, colour,
    texture coordinates), and ``normals`` are the output vertices'.

    Faces meet where their corners share a position, whether or not they
    share a vertex index (an STL file repeats each vertex for every face),
    and the corners of one smooth group become one output vertex -- unless
    ``keep``: then vertices of one position keep apart (a texture seam, a
    colour boundary), each with the group's normal.  Output vertices come in
    order of their position's first vertex, so a mesh without creases or
    repeated positions keeps its numbering.  ``welded``: the caller knows
    no two vertices share a position (an STL reader welded them), so they
    are not hashed again.
    """
    from raytrace.kernels.uncompiled import chosen
    from raytrace.scene import creases
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    n, m = len(v), len(f)
    if m == 0:
        return np.arange(n), f.reshape(0, 3), np.zeros((n, 3))
    # A small mesh's first split runs the kernels as Python (kernels/uncompiled.py).
    corner_lists, fan_groups, fan_normals = (chosen(k, 3 * m) for k in (
        creases.corner_lists, creases.fan_groups, creases.fan_normals))
    position, n_positions = (None, n) if welded else _positions(v)
    pf = f if position is None else position[f]
    corner_position = pf.reshape(-1)
    offsets = np.zeros(n_positions + 1, np.int64)
    np.cumsum(np.bincount(corner_position, minlength=n_positions), out=offsets[1:])
    corners = np.empty(3 * m, np.int64)
    corner_lists(corner_position, offsets, corners, np.empty(n_positions, np.int64))
    del corner_position
    packed = np.empty(3 * m, np.int64)
    counts = np.zeros(n_positions, np.int64)
    cos_crease = math.cos(math.radians(crease))
    position_runs = _runs(offsets)
    # Each run's scratch, for its widest fan (the kernels allocate nothing).
    fans = np.diff(offsets)
    scratch = [creases.fan_scratch(int(fans[a:b].max())) for a, b in position_runs]
    fn, angles = face_frames(v, f)
    _on_threads(fan_groups, [(fn, f, pf, offsets, corners, cos_crease, bool(keep), a, b, packed,
                              counts, work) for (a, b), work in zip(position_runs, scratch)])
    del pf, position
    out_offsets = np.zeros(n_positions + 1, np.int64)
    np.cumsum(counts, out=out_offsets[1:])
    del counts
    n_out = int(out_offsets[-1])
    source = np.empty(n_out, np.int64)
    normals = np.empty((n_out, 3))
    _on_threads(fan_normals, [(fn, angles, f, offsets, corners, out_offsets, a, b, packed, source,
                               normals, work) for (a, b), work in zip(position_runs, scratch)])
    return source, packed.reshape(m, 3), normals


def _threads(n_corners):
    """Threads for work over n_corners corners: one for each 2^16, at most Numba's."""
    import numba
    return max(1, min(numba.get_num_threads(), (int(n_corners) >> 16) + 1))


def _runs(offsets):
    """Runs of positions, one a thread, of about equal numbers of corners."""
    threads = _threads(offsets[-1])
    cuts = np.searchsorted(offsets, [offsets[-1] * k // threads for k in range(threads + 1)])
    cuts[0], cuts[-1] = 0, len(offsets) - 1
    return [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def _face_runs(m):
    """Runs of m faces, one a thread."""
    from raytrace.kernels.threads import runs
    return runs(m, _threads(3 * m))


def _on_threads(kernel, calls):
    from functools import partial

    from raytrace.kernels.threads import run_on_threads
    run_on_threads([partial(kernel, *args) for args in calls])


def _positions(v):
    """(id of each vertex's position, number of positions): vertices with
    the same coordinates, bit for bit, share an id, numbered in order of
    their first vertex.  (None, n) when no two vertices share a position,
    the usual case for a PLY or glTF."""
    ids, first, count = equal_rows(np.ascontiguousarray(v, dtype=np.float64))
    return (None, count) if count == len(v) else (ids, count)


def equal_rows(a, values=None):
    """(ids, values, count) of the rows of a 2-D array, compared bit for
    bit: ids[i] numbers row i's value in order of first appearance, and
    values[k] is value k (scene/weld.py).  ``values``: how many the caller
    expects (the table's first size), all the rows if None."""
    from raytrace.scene.weld import first_rows, new_table
    if len(a) >= 1 << 31:
        raise ValueError("more than 2^31 vertices")
    keys = a.view(np.uint32).reshape(len(a), -1)
    ids = np.empty(len(a), np.int64)
    # At its bound: only the values' rows are ever written (pages never
    # written take no memory).
    out = np.empty_like(keys)
    _, count = first_rows(keys, ids, out, new_table(len(a) if values is None else values), 0)
    return ids, out[:count].view(a.dtype).reshape(count, *a.shape[1:]), count


def file_normals(vertices, faces, normals):
    """A file's vertex normals made unit length; a zero, NaN or infinite one
    is replaced by the angle-weighted normal of the faces around it (zero
    if they are all degenerate: the renderer then uses the face normal)."""
    nrm = np.array(normals, dtype=np.float64)
    # Column by column: NumPy's reductions along rows of 3 are slow.
    x, y, z = nrm.T
    nrm[~(np.isfinite(x) & np.isfinite(y) & np.isfinite(z))] = 0.0
    nrm = unit_rows(nrm)
    x, y, z = nrm.T
    bad = (x == 0.0) & (y == 0.0) & (z == 0.0)
    if bad.any():
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
        fn, angles = face_frames(v, f)
        w = angles[:, :, None] * fn[:, None, :]
        summed = np.zeros_like(v)
        np.add.at(summed, f.ravel(), w.reshape(-1, 3))
        nrm[bad] = unit_rows(summed[bad])
    return nrm


def shading_normals(vertices, faces, normals=None, crease=DEFAULT_CREASE, flat=False):
    """(vertices, faces, normals) as a Mesh takes them: normals None (flat
    shading) with ``flat``; the file's ``normals`` if it has them; else
    computed, split at ``crease`` degrees."""
    source, f, n = shading_split(vertices, faces, normals, crease, flat)
    return (vertices if source is None else np.asarray(vertices)[source]), f, n


def shading_split(vertices, faces, normals=None, crease=DEFAULT_CREASE, flat=False, keep=False,
                  welded=False):
    """shading_normals as (source, faces, normals): output vertex i copies
    input vertex ``source[i]``, or source is None when the vertices stay as
    they are.  A caller applies ``source`` to every per-vertex array it
    holds (positions, colours, texture coordinates), so they all follow the
    split; ``keep`` and ``welded``: see crease_split."""
    if flat:
        return None, faces, None
    if normals is not None:
        return None, faces, file_normals(vertices, faces, normals)
    return crease_split(vertices, faces, crease, keep, welded)
