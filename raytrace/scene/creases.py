"""Smooth vertex normals split at creases, one vertex position at a time
(normals.py's ``crease_split`` prepares the arrays and explains the rules).

The corners at a position (its "fan", listed in corner order by
``corner_lists``) are joined into smooth groups through the edges their
faces share, where the two faces' normals are within the crease angle;
``fan_groups`` finds the groups and numbers the output vertices of the
position, ``fan_normals`` writes them.  A position's work reads only its
own fan and writes only its own corners and output rows, so runs of
positions go to threads with nothing shared.  Each face's unit normal
and corner angles are made once, in a pass over the faces
(``face_frames``), where a fan's corners made them again at each of a
face's three corners from three random reads of its vertices; the
grouping reads the normals, the sums both.  The normals' arithmetic is
flatten.cross_rows's and flatten.unit_rows's, operation for operation; the
angles (the arctan2 of twice the area and a dot product) are libm's, and
every caller gets them here (normals.face_frames).  ``math.atan2``, not
``np.arctan2``: both are libm's compiled, but run as Python on a small
mesh (kernels/uncompiled.py) NumPy's is its own.
"""
import math

import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD, BUILD_STEP
from raytrace.kernels.vector import unit3

# Without the reference-counting runtime: the kernels allocate nothing,
# their scratch comes from the caller (normals.crease_split), and a slice
# of an array costs no count kept.
ENTRY = dict(BUILD, nogil=True, _nrt=False)
STEP = dict(BUILD_STEP, _nrt=False)
# A fan of more corners than this pairs its edges by sorting (a cone's
# apex, a fan-triangulated polygon) rather than by testing every pair.
SMALL_FAN = 24
LABEL_BITS = 32
LABEL_MASK = (1 << LABEL_BITS) - 1


@njit(**ENTRY)
def corner_lists(corner_position, offsets, corners, fill):
    """Each position's corners, in corner order (a counting sort):
    corners[offsets[p]:offsets[p + 1]] are those at position p.  fill:
    scratch, a row a position."""
    for p in range(len(fill)):
        fill[p] = offsets[p]
    for c in range(len(corner_position)):
        p = corner_position[c]
        corners[fill[p]] = c
        fill[p] += 1


@njit(**STEP)
def face_frame(v, f, face, fn, angles):
    """fn[face] = flatten.unit_rows(flatten.cross_rows(e1, e2)) of the face,
    angles[face, k] = its angle at corner k: the arctan2 of twice its area
    and the dot product of the corner's two edges."""
    a, b, d = f[face, 0], f[face, 1], f[face, 2]
    e1x, e1y, e1z = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
    e2x, e2y, e2z = v[d, 0] - v[a, 0], v[d, 1] - v[a, 1], v[d, 2] - v[a, 2]
    e3x, e3y, e3z = v[d, 0] - v[b, 0], v[d, 1] - v[b, 1], v[d, 2] - v[b, 2]
    cx = e1y * e2z - e1z * e2y
    cy = e1z * e2x - e1x * e2z
    cz = e1x * e2y - e1y * e2x
    area2 = np.sqrt(cx * cx + cy * cy + cz * cz)
    angles[face, 0] = math.atan2(area2, e1x * e2x + e1y * e2y + e1z * e2z)
    angles[face, 1] = math.atan2(area2, -(e1x * e3x + e1y * e3y + e1z * e3z))
    angles[face, 2] = math.atan2(area2, e2x * e3x + e2y * e3y + e2z * e3z)
    fn[face, 0], fn[face, 1], fn[face, 2] = unit3(cx, cy, cz)


@njit(**STEP)
def _before(key, i, j):
    return key[i] < key[j] or (key[i] == key[j] and i < j)


@njit(**STEP)
def _sift(key, order, root, end):
    while 2 * root + 1 < end:
        child = 2 * root + 1
        if child + 1 < end and _before(key, order[child], order[child + 1]):
            child += 1
        if not _before(key, order[root], order[child]):
            return
        order[root], order[child] = order[child], order[root]
        root = child


@njit(**STEP)
def sort_order(key, order, n):
    """order[:n] = the indices of key[:n] in order of (key, index): a stable
    argsort, by heapsort (NumPy's argsort here added about 4 s of CPU to
    the cold compile)."""
    for i in range(n):
        order[i] = i
    for root in range(n // 2 - 1, -1, -1):
        _sift(key, order, root, n)
    for end in range(n - 1, 0, -1):
        order[0], order[end] = order[end], order[0]
        _sift(key, order, 0, end)


@njit(**STEP)
def find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(**STEP)
def join(parent, i, j):
    """Union, the smaller index the root: a group's root is its first corner."""
    ri, rj = find(parent, i), find(parent, j)
    if ri < rj:
        parent[rj] = ri
    elif rj < ri:
        parent[ri] = rj


@njit(**STEP)
def link_if_smooth(fan, far, nrm, cos_crease, parent, i, j):
    """Join fan corners i and j if their faces differ, share an edge at
    this position (far[i] holds the positions at its face's other two
    corners) and bend by at most the crease angle."""
    if fan[i] // 3 == fan[j] // 3:
        return
    ai, bi, aj, bj = far[i, 0], far[i, 1], far[j, 0], far[j, 1]
    if not (ai == aj or ai == bj or bi == aj or bi == bj):
        return
    if nrm[i, 0] * nrm[j, 0] + nrm[i, 1] * nrm[j, 1] + nrm[i, 2] * nrm[j, 2] >= cos_crease:
        join(parent, i, j)


@njit(**STEP)
def group_fan(fan, far, nrm, cos_crease, parent, key, order):
    """parent[:d] = each fan corner's group root (its first corner).  key,
    order: scratch of 2 d rows."""
    d = len(fan)
    for i in range(d):
        parent[i] = i
    if d <= SMALL_FAN:
        for i in range(d):
            for j in range(i):
                link_if_smooth(fan, far, nrm, cos_crease, parent, i, j)
    else:
        # Each corner's two edges keyed by the position at their far end:
        # corners whose faces share an edge are then neighbours once sorted.
        for i in range(d):
            key[2 * i] = far[i, 0]
            key[2 * i + 1] = far[i, 1]
        sort_order(key, order, 2 * d)
        start = 0
        for t in range(1, 2 * d + 1):
            if t == 2 * d or key[order[t]] != key[order[start]]:
                for u in range(start, t):
                    for w in range(start, u):
                        link_if_smooth(fan, far, nrm, cos_crease, parent, order[u] // 2,
                                       order[w] // 2)
                start = t
    for i in range(d):
        parent[i] = find(parent, i)


@njit(**ENTRY)
def face_frames(v, f, first, last, fn, angles):
    """face_frame of faces [first, last): each face's unit normal into
    ``fn`` and its corner angles into ``angles`` (m, 3)."""
    for face in range(first, last):
        face_frame(v, f, face, fn, angles)


@njit(**ENTRY)
def fan_groups(fn, f, pf, offsets, corners, cos_crease, keep, first, last, packed, counts, scratch):
    """For positions [first, last): each corner's (group, output vertex)
    numbers within its position, packed as group << 32 | vertex into
    ``packed``, and the position's number of output vertices into
    ``counts``.  A group is one output vertex, or with ``keep`` one per
    input vertex index in it (vertices at one position may carry different
    colours or texture coordinates).  fn: the faces' unit normals
    (face_frames).  scratch: fan_scratch's arrays for the widest fan."""
    parent, gid, label, key, order, nrm, far = scratch
    for p in range(first, last):
        fan = corners[offsets[p]:offsets[p + 1]]
        d = len(fan)
        for i in range(d):
            c = fan[i]
            face, k = c // 3, c % 3
            nrm[i, 0], nrm[i, 1], nrm[i, 2] = fn[face, 0], fn[face, 1], fn[face, 2]
            far[i, 0], far[i, 1] = pf[face, (k + 1) % 3], pf[face, (k + 2) % 3]
        group_fan(fan, far, nrm, cos_crease, parent, key, order)
        n_groups = 0
        for i in range(d):
            if parent[i] == i:
                gid[i] = n_groups
                n_groups += 1
            else:
                gid[i] = gid[parent[i]]
        if not keep:
            for i in range(d):
                label[i] = gid[i]
            n_labels = n_groups
        else:
            n_labels = vertex_labels(f, fan, gid, label, key, order)
        for i in range(d):
            packed[fan[i]] = (gid[i] << LABEL_BITS) | label[i]
        counts[p] = n_labels


@njit(**STEP)
def vertex_labels(f, fan, gid, label, key, order):
    """label[:d]: one number per distinct (group, input vertex) of the fan,
    in order of first corner; returns how many.  key, order: scratch."""
    d = len(fan)
    n = 0
    if d <= SMALL_FAN:
        for i in range(d):
            vi = f[fan[i] // 3, fan[i] % 3]
            label[i] = -1
            for j in range(i):
                if gid[j] == gid[i] and f[fan[j] // 3, fan[j] % 3] == vi:
                    label[i] = label[j]
                    break
            if label[i] < 0:
                label[i] = n
                n += 1
        return n
    for i in range(d):
        key[i] = f[fan[i] // 3, fan[i] % 3] * d + gid[i]
    sort_order(key, order, d)     # stable: a run's first is its first corner
    for t in range(d):
        i = order[t]
        if t > 0 and key[order[t - 1]] == key[i]:
            label[i] = order[t - 1]               # a local index, turned into a label below
        else:
            label[i] = -1
    for i in range(d):
        if label[i] < 0:
            label[i] = n
            n += 1
        else:
            label[i] = label[label[i]]
    return n


@njit(**ENTRY)
def fan_normals(fn, angles, f, offsets, corners, out_offsets, first, last, packed, source,
                normals, scratch):
    """For positions [first, last): each group's angle-weighted normal
    (Thürmer & Wüthrich 1998), its output vertices' rows of ``normals``
    and ``source`` (the input vertex each copies), and each corner's
    output vertex, written over its ``packed`` entry.  fn, angles: the
    faces' unit normals and corner angles (face_frames).  scratch:
    fan_scratch's arrays for the widest fan."""
    first_corner, summed = scratch[0], scratch[5]
    for p in range(first, last):
        fan = corners[offsets[p]:offsets[p + 1]]
        d = len(fan)
        n_groups = 0
        for i in range(d):
            g = packed[fan[i]] >> LABEL_BITS
            if g == n_groups:              # groups are numbered by first corner
                summed[g, 0] = 0.0
                summed[g, 1] = 0.0
                summed[g, 2] = 0.0
                first_corner[g] = fan[i]
                n_groups += 1
            face = fan[i] // 3
            nx, ny, nz, angle = fn[face, 0], fn[face, 1], fn[face, 2], angles[face, fan[i] % 3]
            summed[g, 0] += angle * nx
            summed[g, 1] += angle * ny
            summed[g, 2] += angle * nz
        for g in range(n_groups):
            nx, ny, nz = unit3(summed[g, 0], summed[g, 1], summed[g, 2])
            if nx == 0.0 and ny == 0.0 and nz == 0.0:
                # Cancelled, or every face degenerate: the group's first face's normal.
                face = first_corner[g] // 3
                nx, ny, nz = fn[face, 0], fn[face, 1], fn[face, 2]
            summed[g, 0], summed[g, 1], summed[g, 2] = nx, ny, nz
        base = out_offsets[p]
        for i in range(d):
            c = fan[i]
            g, o = packed[c] >> LABEL_BITS, base + (packed[c] & LABEL_MASK)
            packed[c] = o
            source[o] = f[c // 3, c % 3]
            normals[o, 0], normals[o, 1], normals[o, 2] = summed[g, 0], summed[g, 1], summed[g, 2]


def fan_scratch(widest):
    """fan_groups's and fan_normals's scratch for fans of at most ``widest``
    corners: parent, gid, label, key and order (int64), normals (widest, 3)
    float64 and far corners (widest, 2) int64."""
    ints = [np.empty(n, np.int64) for n in (widest, widest, widest, 2 * widest, 2 * widest)]
    return (*ints, np.empty((widest, 3)), np.empty((widest, 2), np.int64))
