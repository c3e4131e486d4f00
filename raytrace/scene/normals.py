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

Vectorised NumPy throughout: a 1M-triangle mesh takes well under a second
(docs/benchmarks.md, "Scene"; docs/history.md).
"""
import math

import numpy as np

from raytrace.options import CREASE
from raytrace.scene.flatten import cross_rows, unit_rows

DEFAULT_CREASE = CREASE.default   # degrees; why 35: docs/design.md, "The scene"


def face_normals(vertices, faces):
    """Unit normal of each face by its winding; zero for a degenerate face."""
    return unit_rows(_face_frame(vertices, faces)[0])


def _face_frame(vertices, faces):
    """(cross products (m, 3), corner angles (m, 3) in radians) of the
    faces.  Twice the area is the same at every corner, so one cross
    product gives every angle; a zero-length edge gives 0, never NaN
    (atan2(0, 0) = 0)."""
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    e1, e2, e3 = v1 - v0, v2 - v0, v2 - v1
    cross = cross_rows(e1, e2)
    area2 = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    dots = (np.einsum("ij,ij->i", e1, e2), -np.einsum("ij,ij->i", e1, e3),
            np.einsum("ij,ij->i", e2, e3))
    return cross, np.stack([np.arctan2(area2, d) for d in dots], axis=1)


def crease_normals(vertices, faces, crease=DEFAULT_CREASE):
    """(vertices, faces, normals) with smooth normals split at creases.

    Faces whose normals differ by more than ``crease`` degrees do not share
    a normal at their common edge's vertices; such a vertex is copied once
    per smooth group (appended after the original vertices, whose indices
    stay as they were), so a cube's faces use 24 vertices and 6 normals and
    a sphere keeps its vertices.  A group whose weighted normals cancel takes
    one of its faces' normals.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n, m = len(v), len(f)
    if m == 0:
        return v, f, np.zeros_like(v)
    cross, angles = _face_frame(v, f)
    fn = unit_rows(cross)
    corner_vertex = f.ravel()                     # corner c = 3 * face + k
    # Faces meet where their corners share a position, whether or not they
    # share a vertex index: an STL file repeats each vertex for every face.
    position, n_positions = _positions(v)
    groups = _smooth_groups(position[f], n_positions, fn, math.cos(math.radians(crease)))

    # One output vertex per group: a vertex's first group (smallest root)
    # keeps its index, further groups are appended.
    # (Masks and minimum.at, not np.unique: NumPy 2's hashed unique is slow
    # on millions of corners.)
    is_root = groups == np.arange(len(groups))
    roots = np.flatnonzero(is_root)
    group_of_corner = (np.cumsum(is_root) - 1)[groups]
    root_vertex = corner_vertex[roots]
    first_root = np.full(n, len(roots))
    np.minimum.at(first_root, root_vertex, np.arange(len(roots)))
    first = first_root[root_vertex] == np.arange(len(roots))
    new_index = np.where(first, root_vertex, n + np.cumsum(~first) - 1)
    out_v = np.concatenate([v, v[root_vertex[~first]]])

    summed = np.stack([np.bincount(group_of_corner, weights=(angles * fn[:, a, None]).ravel(),
                                   minlength=len(roots)) for a in range(3)], axis=1)
    normals = unit_rows(summed)
    # Cancelled (or all faces degenerate): the normal of the group's first face.
    flat = ~normals.any(axis=1)
    normals[flat] = fn[roots[flat] // 3]
    out_n = np.zeros_like(out_v)
    out_n[new_index] = normals
    return out_v, new_index[group_of_corner].reshape(m, 3), out_n


def _positions(v):
    """(id of each vertex's position, number of positions): vertices with
    the same coordinates, bit for bit, share an id."""
    bits = np.ascontiguousarray(v).view(np.int64)
    order = np.lexsort(bits.T[::-1])
    ordered = bits[order]
    new = np.ones(len(v), dtype=bool)
    new[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    ids = np.empty(len(v), dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, int(new.sum())


def _smooth_groups(f, n, fn, cos_crease):
    """For each corner, the smallest corner index of its smooth group: the
    corners at the same position (``f`` holds the n position ids) linked
    through edges shared by two faces whose normals are within the crease
    angle."""
    # Half-edge h = 3 * face + k runs from corner k to corner k + 1.
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * (n + 1) + np.maximum(a, b)
    order = np.argsort(key)
    ks = key[order]
    # Half-edges on one edge are adjacent once sorted: link each to the next
    # (an edge of three or more faces becomes a chain).
    paired = ks[1:] == ks[:-1]
    pair = np.flatnonzero(paired)
    h1, h2 = order[pair], order[pair + 1]
    f1, f2 = h1 // 3, h2 // 3
    smooth = (np.einsum("ij,ij->i", fn[f1], fn[f2]) >= cos_crease) & (f1 != f2)
    # A vertex on no crease and no open edge has one group: all its corners.
    # Only the others need the search for components.
    lone = np.ones(len(a), dtype=bool)
    lone[1:] &= ~paired
    lone[:-1] &= ~paired
    creased = np.zeros(n, dtype=bool)
    for h in (h1[~smooth], h2[~smooth], order[lone]):
        creased[a[h]] = creased[b[h]] = True
    labels = np.full(n, len(a))
    np.minimum.at(labels, a, np.arange(len(a)))
    labels = labels[a]                             # the vertex's first corner
    at_crease = creased[a]
    labels[at_crease] = np.flatnonzero(at_crease)
    h1, h2 = h1[smooth], h2[smooth]
    near = creased[a[h1]] | creased[b[h1]]
    h1, h2 = h1[near], h2[near]
    # Corners of h1 at its two ends, and the corners of h2's face at the same
    # vertices (h2 runs the other way, unless the windings disagree).
    nxt = h1 - h1 % 3 + (h1 % 3 + 1) % 3, h2 - h2 % 3 + (h2 % 3 + 1) % 3
    same = a[h2] == a[h1]
    la = np.concatenate([h1, nxt[0]])
    lb = np.concatenate([np.where(same, h2, nxt[1]), np.where(same, nxt[1], h2)])
    keep = creased[a[la]]
    return _components(labels, la[keep], lb[keep])


def _components(parent, a, b):
    """Connected components of nodes linked by pairs (a[i], b[i]), starting
    from ``parent`` (each node its own root, or already joined to a smaller
    node that is a root): each node's label becomes the smallest node of
    its component.  Each round hooks the larger of two roots onto the
    smaller, then jumps pointers (Shiloach & Vishkin 1982), in whole-array
    steps over the linked nodes only: a few rounds for a mesh's fans."""
    linked = np.zeros(len(parent), dtype=bool)
    linked[a] = linked[b] = True
    nodes = np.flatnonzero(linked)
    while True:
        ra, rb = parent[a], parent[b]
        todo = ra != rb
        if not todo.any():
            return parent
        a, b, ra, rb = a[todo], b[todo], ra[todo], rb[todo]
        np.minimum.at(parent, np.maximum(ra, rb), np.minimum(ra, rb))
        while True:
            up = parent[parent[nodes]]
            if np.array_equal(up, parent[nodes]):
                break
            parent[nodes] = up


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
        cross, angles = _face_frame(v, f)
        w = angles[:, :, None] * unit_rows(cross)[:, None, :]
        summed = np.zeros_like(v)
        np.add.at(summed, f.ravel(), w.reshape(-1, 3))
        nrm[bad] = unit_rows(summed[bad])
    return nrm


def shading_normals(vertices, faces, normals=None, crease=DEFAULT_CREASE, flat=False):
    """(vertices, faces, normals) as a Mesh takes them: normals None (flat
    shading) with ``flat``; the file's ``normals`` if it has them; else
    computed, split at ``crease`` degrees."""
    if flat:
        return vertices, faces, None
    if normals is not None:
        return vertices, faces, file_normals(vertices, faces, normals)
    return crease_normals(vertices, faces, crease)
