"""The binary tree collapsed to the 4-wide tree traversal reads (layout.BVH):
each node adopts its grandchildren until it has WIDTH children."""

import numpy as np
from numba import njit

from raytrace.accel.bvh.boxes import half_area, round_down, round_up
from raytrace.accel.bvh.layout import BOX, MAX_DEPTH, WIDTH
from raytrace.kernels.jit import BUILD


def collapse_bvh4(node_lo, node_hi, node_start, node_count, links=None):
    """The binary tree as a 4-wide one: (node_box, node_child, node_count4).

    Each wide node takes a binary interior node's two children, then
    repeatedly replaces the interior child with the largest surface area by
    its own two children until it has 4 (Dammertz et al. 2008; the greedy
    choice keeps the boxes a ray most likely enters together in one node).
    The children's boxes are copied as BOX (float32), rounded outwards (lo
    down, hi up) where a builder made them float64, so each still holds its
    primitives and culls only what the float64 box culls: the same hits,
    with half the bytes a node (a ray reads 96 of them a node, not 192).
    Lane j of wide node i: node_box[i, :, j] is
    the box (rows lo x, y, z, hi x, y, z); node_count4[i, j] > 0 makes it a
    leaf over prim_ids[node_child[i, j] : + node_count4[i, j]], 0 an interior
    child, wide node node_child[i, j].  Unused lanes: box lo = hi = +inf,
    which no ray enters, and count 0.  Wide nodes are numbered depth-first.
    A single-leaf tree becomes one wide node with one leaf lane.

    ``links``: for a tree not in one depth-first run of rows (build_bvh_parallel):
    (root, top, top_first, n_inner): the root's row, the rows before
    ``top``, whose first child is top_first[row] instead of row + 1, and
    the number of interior nodes.
    """
    m = len(node_start)
    # Every wide node is made of a binary interior node (a lone leaf: the
    # root), and takes up to three: so at most that many, usually about a
    # third.  np.empty: the kernel fills the rows it uses, and the pages of
    # the rest are never touched, so they cost no memory (np.full of this
    # bound and a trimmed copy took 1.8 s and 900 MB at 4.2M triangles).
    if links is None:
        links = (0, 0, np.empty(0, np.int64), int(np.count_nonzero(node_count == 0)))
    root, top, top_first, n_inner = links
    cap = max(n_inner, 1)
    node_box = np.empty((cap, 6, WIDTH), BOX)
    node_child = np.empty((cap, WIDTH), np.int64)
    count4 = np.empty((cap, WIDTH), np.int64)
    if m == 0:
        return node_box[:0], node_child[:0], count4[:0]
    kids = np.empty(WIDTH, np.int64)
    # Pending interior children: (binary node, slot of the wide lane that
    # will point at it).  A wide node pushes at most WIDTH.
    stack = np.empty(((MAX_DEPTH + 2) * WIDTH, 2), np.int64)
    n_wide = collapse_bvh4_kernel(node_lo, node_hi, node_start, node_count, root, top, top_first,
                                  node_box, node_child, count4, kids, stack)
    # Views of the rows used: the rest of each allocation stays untouched.
    return node_box[:n_wide], node_child[:n_wide], count4[:n_wide]


@njit(**BUILD)
def collapse_bvh4_kernel(node_lo, node_hi, node_start, node_count, root, top, top_first,
                         node_box, node_child, count4, kids, stack):
    """collapse_bvh4's loop, into the arrays its caller allocates; returns
    the number of wide nodes."""
    sp = 0
    n_wide = 1
    src = root   # binary node the current wide node is made of
    wide = 0
    while True:
        if node_count[src] > 0:
            n_kids = 1
            kids[0] = src
        else:
            n_kids = 2
            kids[0] = src + 1 if src >= top else top_first[src]
            kids[1] = node_start[src]
            while n_kids < WIDTH:
                best = -1
                best_area = -1.0
                for j in range(n_kids):
                    k = kids[j]
                    if node_count[k] == 0:
                        area = half_area(node_lo[k, 0], node_lo[k, 1], node_lo[k, 2],
                                          node_hi[k, 0], node_hi[k, 1], node_hi[k, 2])
                        if area > best_area:
                            best_area = area
                            best = j
                if best < 0:
                    break
                k = kids[best]
                kids[best] = k + 1 if k >= top else top_first[k]
                kids[n_kids] = node_start[k]
                n_kids += 1
        for j in range(n_kids, WIDTH):          # unused lanes: a box no ray enters
            for a in range(6):
                node_box[wide, a, j] = np.inf
            node_child[wide, j] = -1
            count4[wide, j] = 0
        for j in range(n_kids):
            k = kids[j]
            for a in range(3):
                node_box[wide, a, j] = round_down(node_lo[k, a])
                node_box[wide, 3 + a, j] = round_up(node_hi[k, a])
            count4[wide, j] = 0
            if node_count[k] > 0:
                node_child[wide, j] = node_start[k]
                count4[wide, j] = node_count[k]
            else:
                stack[sp, 0] = k
                stack[sp, 1] = wide * WIDTH + j
                sp += 1
        if sp == 0:
            break
        sp -= 1
        src = stack[sp, 0]
        slot = stack[sp, 1]
        wide = n_wide
        n_wide += 1
        node_child[slot // WIDTH, slot % WIDTH] = wide
    return n_wide
