"""kd-tree build: binned SAH over primitive boxes (the cost model of
pbrt-v3's KdTreeAccel and of Wald & Havran 2006, "On building fast
kd-Trees for Ray Tracing, and on doing that in O(N log N)", here with
binning instead of sorted event lists: O(N) per level).

A node splits its box by an axis-aligned plane; a primitive goes to every
side its box, widened by the grid's insertion tolerance ``grid_eps``,
touches.  That widening is what lets the traversal (accel/kdtree/traverse.py)
return exactly the brute-force answer despite rounding, as for the grid.

A triangle's box in a node is the box of the part of it inside the node
(the triangle clipped to the node's box widened by ``eps``: Wald & Havran
2006's "perfect splits", Sutherland & Hodgman 1974's clipping), not its
whole box: a long diagonal triangle is then listed only in the leaves it
crosses, and one that merely shares a box corner with a node leaves it.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.accel.grid.build import grid_eps
from raytrace.kernels.buffers import FLOAT, INDEX, box_of, prim_bounds
from raytrace.kernels.jit import BUILD, BUILD_STEP

# The layout traversal reads: nodes in depth-first order, a node's first
# child (below its plane) right after it.  node_axis 0, 1, 2: an interior
# node split at node_split along that axis, its second child node_index;
# node_axis LEAF: a leaf over prim_list[node_index : node_index + node_count].
# lo, hi: the tree's bounds, (3,) each.
KdTree = namedtuple("KdTree", ["node_axis", "node_split", "node_index", "node_count",
                               "prim_list", "lo", "hi"])
LEAF = 3

N_BINS = 16            # split candidates per axis and node
TRAVERSAL_COST = 1.0   # one node step against one primitive test (pbrt-v3: 1 and 80, scaled)
EMPTY_BONUS = 0.5      # cost discount for a split with an empty side (pbrt-v3)
MAX_LEAF = 2           # a node this small becomes a leaf
# Leaves are forced at this depth: the traversal's fixed-size stack holds at
# most one pending node a level (accel/kdtree/traverse.py).
MAX_DEPTH = 48


@njit(**BUILD_STEP)
def _half_area(ex, ey, ez):
    return ex * ey + ey * ez + ez * ex


@njit(**BUILD_STEP)
def _clip_bounds(v0, v1, v2, p, bl, bh, eps, poly, tmp, out_lo, out_hi, k):
    """Box of triangle p clipped to [bl - eps, bh + eps] into row k of
    out_lo, out_hi; an empty box (lo +inf, hi -inf) if nothing is left.
    poly and tmp: (10, 3) scratch (a triangle clipped by six planes has at
    most nine corners).  Each cut point is put exactly on its plane, and
    rounding elsewhere is ulps, far below eps: the box stays conservative."""
    for c in range(3):
        poly[0, c] = v0[p, c]
        poly[1, c] = v1[p, c]
        poly[2, c] = v2[p, c]
    m = 3
    for a in range(3):
        for side in range(2):
            plane = bl[a] - eps if side == 0 else bh[a] + eps
            sign = 1.0 if side == 0 else -1.0   # inside: sign * (x[a] - plane) >= 0
            k_out = 0
            for i in range(m):
                j = i + 1 if i + 1 < m else 0
                di = sign * (poly[i, a] - plane)
                dj = sign * (poly[j, a] - plane)
                if di >= 0.0:
                    for c in range(3):
                        tmp[k_out, c] = poly[i, c]
                    k_out += 1
                if (di >= 0.0) != (dj >= 0.0):
                    t = di / (di - dj)
                    for c in range(3):
                        tmp[k_out, c] = poly[i, c] + t * (poly[j, c] - poly[i, c])
                    tmp[k_out, a] = plane
                    k_out += 1
            m = k_out
            for i in range(m):
                for c in range(3):
                    poly[i, c] = tmp[i, c]
            if m == 0:
                for c in range(3):
                    out_lo[k, c] = np.inf
                    out_hi[k, c] = -np.inf
                return
    for c in range(3):
        out_lo[k, c] = poly[0, c]
        out_hi[k, c] = poly[0, c]
    for i in range(1, m):
        for c in range(3):
            out_lo[k, c] = min(out_lo[k, c], poly[i, c])
            out_hi[k, c] = max(out_hi[k, c], poly[i, c])


@njit(**BUILD)
def build_kdtree_kernel(lo, hi, v0, v1, v2, glo, ghi, eps, max_depth):
    """Returns (node_axis, node_split, node_index, node_count, prim_list).
    Primitives below v0.shape[0] are the triangles (v0, v1, v2) and are
    clipped to each node; the others are taken by their boxes."""
    n = lo.shape[0]
    n_tris = v0.shape[0]
    poly = np.empty((10, 3), np.float64)
    tmp = np.empty((10, 3), np.float64)
    child_lo = np.empty(3, np.float64)
    child_hi = np.empty(3, np.float64)
    cap = max(16, 4 * n)
    axis_of = np.empty(cap, np.int64)
    split_of = np.empty(cap, np.float64)
    index_of = np.empty(cap, np.int64)
    count_of = np.empty(cap, np.int64)
    pcap = max(16, 4 * n)
    plist = np.empty(pcap, np.int64)
    n_plist = 0
    # Work: the primitives of pending nodes live in a scratch list; each
    # stack entry is (start, count, depth, parent, box lo xyz, box hi xyz).
    scap = max(16, 4 * n)
    scratch = np.empty(scap, np.int64)
    # Beside each entry, the primitive's box within that node: its whole
    # box at the root, clipped where a split plane cut it.
    sb_lo = np.empty((scap, 3), np.float64)
    sb_hi = np.empty((scap, 3), np.float64)
    for i in range(n):
        scratch[i] = i
        for c in range(3):
            sb_lo[i, c] = lo[i, c]
            sb_hi[i, c] = hi[i, c]
    top = n
    st_i = np.empty((max_depth + 2, 4), np.int64)
    st_f = np.empty((max_depth + 2, 6), np.float64)
    sp = 0
    cnt_lo = np.empty((3, N_BINS), np.int64)
    cnt_hi = np.empty((3, N_BINS), np.int64)
    n_nodes = 0
    start, count, depth, parent = 0, n, 0, -1
    bl = np.array([glo[0], glo[1], glo[2]])
    bh = np.array([ghi[0], ghi[1], ghi[2]])
    while True:
        if n_nodes == cap:
            cap *= 2
            axis_of = _grow_i(axis_of, cap)
            split_of = _grow_f(split_of, cap)
            index_of = _grow_i(index_of, cap)
            count_of = _grow_i(count_of, cap)
        node = n_nodes
        n_nodes += 1
        if parent >= 0:
            index_of[parent] = node     # this is parent's second child
        ex, ey, ez = bh[0] - bl[0], bh[1] - bl[1], bh[2] - bl[2]
        area = _half_area(ex, ey, ez)
        best_cost = np.inf
        best_axis = -1
        best_split = 0.0
        if count > MAX_LEAF and depth < max_depth and area > 0.0:
            cnt_lo[:, :] = 0
            cnt_hi[:, :] = 0
            for k in range(start, start + count):
                for a in range(3):
                    w = bh[a] - bl[a]
                    if w > 0.0:
                        b0 = int((sb_lo[k, a] - eps - bl[a]) / w * N_BINS)
                        b1 = int((sb_hi[k, a] + eps - bl[a]) / w * N_BINS)
                        cnt_lo[a, min(max(b0, 0), N_BINS - 1)] += 1
                        cnt_hi[a, min(max(b1, 0), N_BINS - 1)] += 1
            for a in range(3):
                w = bh[a] - bl[a]
                if w <= 0.0:
                    continue
                n_below = 0
                n_ended = 0
                for b in range(1, N_BINS):
                    n_below += cnt_lo[a, b - 1]   # started below this plane
                    n_ended += cnt_hi[a, b - 1]   # ended below it
                    n_above = count - n_ended
                    t = b / N_BINS
                    e = (ex, ey, ez)
                    # Child boxes: the node's, cut at the plane.
                    wa = e[a] * t
                    wb = e[a] - wa
                    if a == 0:
                        area_b = _half_area(wa, ey, ez)
                        area_a = _half_area(wb, ey, ez)
                    elif a == 1:
                        area_b = _half_area(ex, wa, ez)
                        area_a = _half_area(ex, wb, ez)
                    else:
                        area_b = _half_area(ex, ey, wa)
                        area_a = _half_area(ex, ey, wb)
                    bonus = EMPTY_BONUS if n_below == 0 or n_above == 0 else 0.0
                    cost = TRAVERSAL_COST + (1.0 - bonus) * (area_b * n_below
                                                             + area_a * n_above) / area
                    if cost < best_cost:
                        best_cost = cost
                        best_axis = a
                        best_split = bl[a] + wa
        if best_axis >= 0 and best_cost < count:
            a = best_axis
            s = best_split
            # Left list, then right list, appended to the scratch top.
            if top + 2 * count > scap:
                scap = max(2 * scap, top + 2 * count)
                scratch = _grow_i(scratch, scap)
                sb_lo = _grow_f3(sb_lo, scap)
                sb_hi = _grow_f3(sb_hi, scap)
            # The lists below and above the plane, each with its child's box.
            # Copied here rather than by a helper: a call passing arrays under
            # the runtime counts their references each time (5x slower build).
            left = right = top
            for side in range(2):
                for c in range(3):
                    child_lo[c] = bl[c]
                    child_hi[c] = bh[c]
                if side == 0:
                    child_hi[a] = s
                else:
                    child_lo[a] = s
                    right = top
                for k in range(start, start + count):
                    below = sb_lo[k, a] - eps <= s
                    above = sb_hi[k, a] + eps >= s
                    if not (below if side == 0 else above):
                        continue
                    p = scratch[k]
                    scratch[top] = p
                    if p < n_tris and below and above:   # cut by the plane: clip it
                        _clip_bounds(v0, v1, v2, p, child_lo, child_hi, eps, poly, tmp, sb_lo,
                                     sb_hi, top)
                        if sb_lo[top, 0] > sb_hi[top, 0]:
                            continue   # nothing of it on this side
                    else:
                        for c in range(3):
                            sb_lo[top, c] = sb_lo[k, c]
                            sb_hi[top, c] = sb_hi[k, c]
                    top += 1
            n_left = right - left
            n_right = top - right
            axis_of[node] = a
            split_of[node] = s
            count_of[node] = 0
            # Right child waits on the stack with its box; the left is next.
            st_i[sp, 0] = right
            st_i[sp, 1] = n_right
            st_i[sp, 2] = depth + 1
            st_i[sp, 3] = node
            for j in range(3):
                st_f[sp, j] = bl[j]
                st_f[sp, 3 + j] = bh[j]
            st_f[sp, a] = s
            sp += 1
            bh[a] = s
            start, count, depth, parent = left, n_left, depth + 1, -1
        else:
            axis_of[node] = LEAF
            split_of[node] = 0.0
            if n_plist + count > pcap:
                pcap = max(2 * pcap, n_plist + count)
                plist = _grow_i(plist, pcap)
            index_of[node] = n_plist
            count_of[node] = count
            for k in range(start, start + count):
                plist[n_plist] = scratch[k]
                n_plist += 1
            if sp == 0:
                break
            sp -= 1
            start, count, depth, parent = st_i[sp, 0], st_i[sp, 1], st_i[sp, 2], st_i[sp, 3]
            for j in range(3):
                bl[j] = st_f[sp, j]
                bh[j] = st_f[sp, 3 + j]
            # The scratch above the popped right list is free again.
            top = start + count
    return (axis_of[:n_nodes].copy(), split_of[:n_nodes].copy(), index_of[:n_nodes].copy(),
            count_of[:n_nodes].copy(), plist[:n_plist].copy())


@njit(**BUILD_STEP)
def _grow_f3(a, size):
    out = np.empty((size, 3), np.float64)
    for i in range(a.shape[0]):   # a loop: a slice copy compiles a shape-error message (~1 s cold)
        for c in range(3):
            out[i, c] = a[i, c]
    return out


@njit(**BUILD_STEP)
def _grow_i(a, size):
    out = np.empty(size, np.int64)
    for i in range(a.shape[0]):   # a loop: a slice copy compiles a shape-error message (~1 s cold)
        out[i] = a[i]
    return out


@njit(**BUILD_STEP)
def _grow_f(a, size):
    out = np.empty(size, np.float64)
    for i in range(a.shape[0]):   # a loop: a slice copy compiles a shape-error message (~1 s cold)
        out[i] = a[i]
    return out


def build_kdtree(lo, hi, triangles=None):
    """kd-tree over (n, 3) primitive boxes (row = unified id); the first
    primitives are the triangles ``triangles`` = (v0, v1, v2), (k, 3) each,
    if given, and are clipped to the nodes."""
    lo = np.ascontiguousarray(lo, dtype=FLOAT).reshape(-1, 3)
    hi = np.ascontiguousarray(hi, dtype=FLOAT).reshape(-1, 3)
    none = np.zeros((0, 3), FLOAT)
    v0, v1, v2 = (np.ascontiguousarray(v, dtype=FLOAT).reshape(-1, 3)
                  for v in (triangles or (none, none, none)))
    n = lo.shape[0]
    if n == 0:
        z = np.zeros(0, INDEX)
        return KdTree(z, np.zeros(0, FLOAT), z, z, z, np.zeros(3, FLOAT), np.zeros(3, FLOAT))
    raw_lo, raw_hi = box_of(lo, hi)
    # Bounds padded as the grid's: boundary primitives lie strictly inside.
    pad = 2.0 * grid_eps(raw_lo, raw_hi)
    glo, ghi = raw_lo - pad, raw_hi + pad
    eps = grid_eps(glo, ghi)
    # pbrt-v3's depth limit, 8 + 1.3 log2(N), capped for the stack.
    max_depth = int(min(MAX_DEPTH, round(8 + 1.3 * np.log2(n))))
    axis, split, index, count, plist = build_kdtree_kernel(lo, hi, v0, v1, v2, glo, ghi, eps,
                                                          max_depth)
    return KdTree(axis, split, index, count, plist, glo, ghi)


def build(geo, obj_ranges, **_):
    return build_kdtree(*prim_bounds(geo), triangles=(geo.tri_v0, geo.tri_v1, geo.tri_v2))


def empty():
    """A layout of no primitives, of the built ones' types (cast/precompile.py)."""
    return build_kdtree(np.zeros((0, 3)), np.zeros((0, 3)))


def statistics(tree, n_prims):
    """Nodes, leaves, depths, leaf sizes, references (a primitive is listed
    in every leaf it touches: the duplication factor) and memory."""
    from raytrace.accel.statistics import leaves, memory
    m = len(tree.node_axis)
    out = {"nodes": int(m)}
    if m == 0:
        return out | leaves([], []) | memory(tree, n_prims)
    depth = np.zeros(m, np.int64)
    inner = np.flatnonzero(tree.node_axis != LEAF)
    for node in inner:                 # depth-first numbered: parents first
        depth[node + 1] = depth[tree.node_index[node]] = depth[node] + 1
    leaf = tree.node_axis == LEAF
    refs = int(len(tree.prim_list))
    return (out | leaves(tree.node_count[leaf], depth[leaf])
            | {"references": refs, "duplication": refs / n_prims if n_prims else 0.0}
            | memory(tree, n_prims))


def outline(tree, depth):
    """(lo, hi, level) of every cell down to ``depth`` (--show-structure):
    the bounds are level 0; each split's two halves one deeper, so the
    splitting planes show as the faces the halves share."""
    los, his, levels = [], [], []
    stack = [(0, 0, np.array(tree.lo, float), np.array(tree.hi, float))] if len(tree.node_axis) else []
    while stack:
        node, level, lo, hi = stack.pop()
        los.append(lo)
        his.append(hi)
        levels.append(level)
        axis = int(tree.node_axis[node])
        if axis == LEAF or level == depth:
            continue
        below_hi, above_lo = hi.copy(), lo.copy()
        below_hi[axis] = above_lo[axis] = tree.node_split[node]
        stack.append((node + 1, level + 1, lo, below_hi))
        stack.append((int(tree.node_index[node]), level + 1, above_lo, hi))
    return (np.array(los).reshape(-1, 3), np.array(his).reshape(-1, 3),
            np.array(levels, np.int64))
