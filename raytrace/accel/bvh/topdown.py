"""A top-down binary BVH builder driven by a split rule, for the builders
that choose splits without the SAH: the object median (median.py) and
the Morton-code radix split of LBVH (lbvh.py).  Output: the binned-SAH
builder's binary layout (build.py), so collapse_bvh4 and the traversal are
the same for every builder, and so are the images."""
import numpy as np
from numba import njit

from raytrace.accel.bvh.layout import BOX_PAD, LINK, MAX_DEPTH
from raytrace.kernels.jit import BUILD, BUILD_STEP

RULE_MEDIAN, RULE_MORTON = 0, 1


@njit(**BUILD_STEP)
def _median_split(cen, prim_ids, start, end):
    """Partition prim_ids[start:end] about the median centroid on the axis of
    the centroids' widest spread (quickselect); returns the middle index."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for k in range(start, end):
        for a in range(3):
            x = cen[a, prim_ids[k]]
            lo[a] = min(lo[a], x)
            hi[a] = max(hi[a], x)
    axis = 0
    for a in range(1, 3):
        if hi[a] - lo[a] > hi[axis] - lo[axis]:
            axis = a
    mid = start + (end - start) // 2
    left, right = start, end - 1
    while left < right:   # Hoare's quickselect on the centroid coordinate
        pivot = cen[axis, prim_ids[(left + right) // 2]]
        i, j = left, right
        while i <= j:
            while cen[axis, prim_ids[i]] < pivot:
                i += 1
            while cen[axis, prim_ids[j]] > pivot:
                j -= 1
            if i <= j:
                prim_ids[i], prim_ids[j] = prim_ids[j], prim_ids[i]
                i += 1
                j -= 1
        if mid <= j:
            right = j
        elif mid >= i:
            left = i
        else:
            break
    return mid


@njit(**BUILD_STEP)
def _morton_split(codes, start, end):
    """The first index whose sorted Morton code differs from codes[start] in
    the highest bit where codes[start] and codes[end - 1] differ (Karras
    2012's split), by binary search; the middle when all codes are equal."""
    first, last = codes[start], codes[end - 1]
    if first == last:
        return start + (end - start) // 2
    diff = first ^ last
    bit = 63
    while not (diff >> bit) & 1:
        bit -= 1
    prefix = first >> bit
    lo, hi = start, end - 1      # codes[lo] has the prefix, codes[hi] does not
    while hi - lo > 1:
        m = (lo + hi) // 2
        if (codes[m] >> bit) == prefix:
            lo = m
        else:
            hi = m
    return hi


@njit(**BUILD)
def build_topdown(lo, hi, prim_ids, codes, rule, leaf_size):
    """(node_lo, node_hi, node_start, node_count, prim_ids) of the binary
    tree over prim_ids (already in Morton order for RULE_MORTON, whose
    codes are given), leaves of at most leaf_size, flattened depth-first.
    The topology comes first; boxes then bottom-up, in O(n)."""
    n = prim_ids.shape[0]
    cap = max(2 * n - 1, 1)
    node_start = np.empty(cap, LINK)
    node_count = np.empty(cap, LINK)
    cen = np.empty((3, lo.shape[0]))
    if rule == RULE_MEDIAN:
        for i in range(lo.shape[0]):
            for a in range(3):
                cen[a, i] = 0.5 * (lo[i, a] + hi[i, a])
    stack = np.empty((MAX_DEPTH + 2, 4), np.int64)
    sp = 0
    n_nodes = 0
    start, end, depth, parent = 0, n, 0, -1
    while n > 0:
        node = n_nodes
        n_nodes += 1
        if parent >= 0:
            node_start[parent] = node
        count = end - start
        mid = -1
        if count > leaf_size and depth < MAX_DEPTH:
            if rule == RULE_MEDIAN:
                mid = _median_split(cen, prim_ids, start, end)
            else:
                mid = _morton_split(codes, start, end)
        if start < mid < end:
            node_count[node] = 0
            stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3] = mid, end, depth + 1, node
            sp += 1
            end, depth, parent = mid, depth + 1, -1
        else:
            node_start[node] = start
            node_count[node] = count
            if sp == 0:
                break
            sp -= 1
            start, end, depth, parent = stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3]
    # Boxes bottom-up: children come after their parent (depth-first).
    node_lo = np.empty((n_nodes, 3))
    node_hi = np.empty((n_nodes, 3))
    for node in range(n_nodes - 1, -1, -1):
        if node_count[node] > 0:
            for a in range(3):
                node_lo[node, a] = np.inf
                node_hi[node, a] = -np.inf
            for k in range(node_start[node], node_start[node] + node_count[node]):
                p = prim_ids[k]
                for a in range(3):
                    node_lo[node, a] = min(node_lo[node, a], lo[p, a])
                    node_hi[node, a] = max(node_hi[node, a], hi[p, a])
        else:
            c1, c2 = node + 1, node_start[node]
            for a in range(3):
                node_lo[node, a] = min(node_lo[c1, a], node_lo[c2, a])
                node_hi[node, a] = max(node_hi[c1, a], node_hi[c2, a])
    # Padded as the SAH builder pads (build.py, BOX_PAD), once all are known,
    # so children's unpadded boxes made their parents'.
    for node in range(n_nodes):
        m = 0.0
        for a in range(3):
            m = max(m, abs(node_lo[node, a]), abs(node_hi[node, a]))
        pad = BOX_PAD * m
        for a in range(3):
            node_lo[node, a] -= pad
            node_hi[node, a] += pad
    return node_lo, node_hi, node_start[:n_nodes].copy(), node_count[:n_nodes].copy(), prim_ids
