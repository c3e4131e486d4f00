"""BVH traversal: one loop for closest hit and any hit, another for
counting every hit.

The tree is the 4-wide layout of ``raytrace.accel.bvh.build.BVH``: the binned-SAH
binary tree collapsed so each node holds the boxes of up to 4 children.  At
a node all 4 child boxes are tested at once (``ray_aabb4``, SIMD, in
float32 with margins that keep it conservative: ``box_ray``); the
nearest child the ray enters is visited next, kept in registers, and the
others go on a fixed-size stack with their entry distances, sorted so the
nearest is on top.  A popped entry is skipped when a hit closer than its
entry distance has been found since.  Leaves are children too: a stack
entry below zero is a leaf's lane_entry word, ``~(first slot << 32 |
count)``.  A leaf's
triangles are tested 4 at a time (``leaf_hits``) from the tree's copy of
them in leaf order (``leaf_tris``), exactly as the scalar test tests each.
Any hit is the same loop stopped at the first hit (tinybvh's and
madmann91/bvh's IsAnyHit flag, here the compile-time mode of
``_traversal``): until then its best distance is inf, so it tests boxes
against t_max.  Counting every hit never narrows the interval nor stops,
so the order of visits does not matter: its loop (``_count_traverse``)
takes two nodes a round, pushes without sorting or branching, queues the
leaves it enters and tests their triangles 8 at a time
(``crossing_mask``), on a tree of its own (the CountingBVH layout, made on
a scene's first count): a count tests many triangles and hits few.
count_intersections traces two rays at once in that loop, a round of each
in turn (count_stream.py).

The stack lives in the function's frame (``frame_array``, an alloca), not
in ``np.empty``: that would need the reference-counted runtime and a heap
allocation per ray, and a stack passed in as an argument makes LLVM assume
its stores may alias the node arrays and slows every ray
(docs/benchmarks.md, "BVH").  Each node pushes at most 3 entries (the
child it keeps is not pushed), and a 4-wide node lies at most MAX_DEPTH - 1
levels down, so the stack never holds more than 3 * (MAX_DEPTH - 1) + 4
entries.

Conventions shared with every structure (prims.py), so the result is
bit-identical to brute force.  Counters are kept in locals and added to
``cnt`` once per ray.
"""
from collections import namedtuple

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros  # llvm.cttz: a mask's lowest set bit

from raytrace.accel.bvh.layout import BVH, MAX_DEPTH, WIDTH, CountingBVH
from raytrace.accel.bvh.simd import (
    CROSSING_LANES,
    LEAF_LANES,
    box_ray_f32,
    crossing_mask,
    leaf_hits,
    ray_aabb4,
)
from raytrace.kernels.counters import BOX_TESTS, NODES_VISITED, PRIM_HITS, PRIM_TESTS
from raytrace.kernels.jit import JIT, STAGE
from raytrace.kernels.lowlevel import frame_array, popcount
from raytrace.kernels.prims import records_hits, test_prim
from raytrace.kernels.query import ANY_HIT, CLOSEST, register
from raytrace.kernels.ray import Hit, closer, no_hit

STACK_SIZE = 3 * MAX_DEPTH + 4
# Counting takes ROUND nodes a round (_count_round, written out there)
# and pushes their entered inner children above what is left.  What one
# round leaves below the next round's pushes is at most 4 * ROUND - ROUND
# entries, and each such layer's shallowest node lies deeper than the
# shallowest of the layer below (its nodes are children of nodes popped
# from that layer or from layers above it, all at least as deep), so
# there are at most MAX_DEPTH - 1 layers: the stack never holds more than
# COUNT_STACK_SIZE entries.
ROUND = 2
COUNT_STACK_SIZE = 3 * ROUND * (MAX_DEPTH - 1) + WIDTH * ROUND
# Entered leaves waiting for their tests (_count_traverse): a round adds at
# most ROUND * WIDTH.  Random rays through a closed mesh enter ~12 leaves.
QUEUE_SIZE = 64
CHUNK = CROSSING_LANES // 2   # slots of a leaf a crossing test takes at once
_DONE = -(1 << 63)  # "stack empty": below every leaf's lane_entry word

# A ray's constants for the float32 box test (simd.ray_aabb4): the
# rows of its near planes, and on each axis the origin and the inverse
# direction for the near and the far plane.
BoxRay = namedtuple("BoxRay", ["nx", "ny", "nz", "onx", "ony", "onz", "ofx", "ofy", "ofz",
                               "inx", "iny", "inz", "ifx", "ify", "ifz"])
# The inverse direction is shrunk for the near plane and grown for the far
# one by 16 float32 ulps: its own rounding and the test's subtraction and
# product round by at most 3.
BOX32_MARGIN = 2.0 ** -20
# Origins and boxes within 2^62 in magnitude, and near inverses cut to
# 2^63: their products stay below 2^126, and float32's range ends at 2^128.
BOX32_RANGE = 2.0 ** 62
NEAR_LIMIT = 2.0 ** 63


@njit(**JIT)
def _unsigned(i):
    """Index i as Numba indexes without a sign test: a signed index is
    first wrapped (a negative one counts from the end), a test and an add
    at every access.  For indices that cannot be negative."""
    return np.uint64(i)


@njit(**JIT)
def near_rows(ray):
    """Rows of node_box holding the planes a ray meets first on each axis:
    lo (0, 1, 2) for a positive inverse direction, hi (3, 4, 5) otherwise."""
    nx = 3 if ray.inv_x < 0.0 else 0
    ny = 4 if ray.inv_y < 0.0 else 1
    nz = 5 if ray.inv_z < 0.0 else 2
    return nx, ny, nz


@njit(**JIT)
def box_ray(acc, ray):
    """The ray's BoxRay for tree acc (simd.box_ray_f32 makes the
    constants).  A near inverse is cut to NEAR_LIMIT, so its products
    with a box-to-origin difference stay finite; a smaller near inverse
    only lowers a positive entry.  Past BOX32_RANGE (an origin or a box
    beyond 4.6e18), or with an inverse direction below 2^-100, the test
    cannot bound its distances: such a ray gets constants that enter every
    used lane (box_ray_f32), so it visits the whole tree, as brute force
    would, with the same hits."""
    reach = max(abs(ray.ox), abs(ray.oy), abs(ray.oz))
    bounded = (reach <= BOX32_RANGE) & (acc.box_bound <= BOX32_RANGE)
    nx, ny, nz = near_rows(ray)
    c = box_ray_f32(ray.ox, ray.oy, ray.oz, ray.inv_x, ray.inv_y, ray.inv_z, NEAR_LIMIT,
                    BOX32_MARGIN, bounded)
    # Unbounded: rows 0, 1, 2 (nx is 0 or 3, ny 1 or 4, nz 2 or 5).
    return BoxRay(nx * bounded, 1 + (ny - 1) * bounded, 2 + (nz - 2) * bounded,
                  c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11])


@njit(**JIT)
def child_boxes(node_box, node, br, t_box):
    """(mask, entry distances) of the ray whose BoxRay is br against node's
    4 child boxes."""
    return ray_aabb4(node_box, node, br, t_box)


@njit(**JIT)
def _push_children(node_box, lane_entry, node, br, t_box, stack, stack_t, sp):
    """Test node's 4 child boxes: returns (the new stack pointer, the
    lane_entry word of the nearest child the ray enters, or _DONE if none).
    The nearest is not pushed: the traversal visits it next, its word in a
    register, where a push then a pop put a store and a load of the same
    slot between one node's test and the next (4-10% of an incoherent
    ray's time: docs/benchmarks.md, "The next child kept, not pushed").
    The others are pushed nearest on top (insertion into the entries pushed
    here, usually 0 to 2), in the order a push of all of them would leave
    under the nearest: among equal distances the later lane is nearer the
    top, and the last of the nearest is the one kept.  Lanes are chosen by
    the mask's bits rather than by their distances (and a node whose
    children all miss skips the loop), which is faster (docs/benchmarks.md,
    "BVH").  Indices unsigned: sp never goes below 0."""
    mask, d = child_boxes(node_box, node, br, t_box)
    near = _DONE
    if mask == 0:
        return sp, near
    base = sp
    near_d = np.inf
    for lane in range(WIDTH):
        dl = d[lane]
        word = lane_entry[_unsigned(node), lane]     # before the test: as packet._push_children
        if mask & (1 << lane):
            if near == _DONE:
                near, near_d = word, dl
                continue
            if dl <= near_d:        # this lane is kept; the one kept so far is pushed
                word, near = near, word
                dl, near_d = near_d, dl
            k = sp
            while k > base and stack_t[_unsigned(k - 1)] < dl:
                stack[_unsigned(k)] = stack[_unsigned(k - 1)]
                stack_t[_unsigned(k)] = stack_t[_unsigned(k - 1)]
                k -= 1
            stack[_unsigned(k)] = word
            stack_t[_unsigned(k)] = dl
            sp += 1
    return sp, near


@njit(**JIT)
def leaf_slots(entry):
    """prim_ids slots [start, end) of the leaf whose lane_entry word is
    ``entry`` (below zero)."""
    word = ~entry
    start = word >> 32
    return start, start + (word & 0xFFFFFFFF)


@njit(**JIT)
def tally(cnt, n_inner, n_leaves, n_tests, n_hits):
    """Add a traversal's counts, kept in locals, to its counter row: each
    inner node tests WIDTH boxes."""
    cnt[BOX_TESTS] += WIDTH * n_inner
    cnt[NODES_VISITED] += n_inner + n_leaves
    cnt[PRIM_TESTS] += n_tests
    cnt[PRIM_HITS] += n_hits


@njit(**JIT)
def _test_slots(geo, acc, ray, k, n, t_max, best, first):
    """Test the primitives in slots k .. k + n - 1 (n <= 4) at once
    (leaf_hits; test_prim for a sphere's slot); returns the closer of their
    hits and best, and the tests and hits to count.  With ``first`` (any
    hit) the slots count as the scalar loop met them, up to the first hit."""
    m, ts, us, vs = leaf_hits(acc.leaf_tris, k, ray, t_max)
    inside = (1 << n) - 1
    found = m & inside
    todo = found | ((m >> LEAF_LANES) & inside)
    tests = n
    hits = 0
    while todo:
        lane = trailing_zeros(todo)
        p = acc.prim_ids[k + lane]
        if found & (1 << lane):
            t, u, v = ts[lane], us[lane], vs[lane]
        else:
            t, u, v = test_prim(geo, ray, p, t_max)
        todo &= todo - 1
        if t < np.inf:
            hits += 1
            if closer(t, p, best):
                best = Hit(t, p, u, v)
            if first:
                tests = lane + 1
                todo = 0
    return best, tests, hits


# Two callers (the traversal and packet._rays_alone): inlined by Numba into
# each, no library of its own to optimise and emit (kernels/jit.py).
@njit(**STAGE)
def test_leaf(geo, acc, ray, entry, t_max, best, first):
    """The leaf whose lane_entry word is ``entry`` tested LEAF_LANES slots
    at a time (_test_slots); with ``first`` (any hit) up to the first hit.
    Returns (best, tests, hits) as _test_slots does."""
    k, end = leaf_slots(entry)
    tests = 0
    hits = 0
    while k < end and not (first and best.prim >= 0):
        best, n, h = _test_slots(geo, acc, ray, k, min(end - k, LEAF_LANES), t_max, best, first)
        tests += n
        hits += h
        k += LEAF_LANES
    return best, tests, hits


def _traversal(mode):
    @njit(**JIT)
    def traverse(geo, acc, ray, t_max, cnt):
        node_box, lane_entry = acc.node_box, acc.lane_entry
        best = no_hit()
        if node_box.shape[0] == 0:
            return best
        stack = frame_array(STACK_SIZE, np.int64)
        stack_t = frame_array(STACK_SIZE, np.float64)
        br = box_ray(acc, ray)
        # int64s, not literal 0s: tally was compiled for the literals too.
        n_inner = n_leaves = n_tests = n_hits = np.int64(0)
        # int64s, not literal 0s: a call given a literal is compiled again
        # for it (_push_children and leaf_slots were, twice each).
        entry = np.int64(0)
        sp = np.int64(0)
        while entry != _DONE:
            if entry >= 0:
                n_inner += 1
                sp, near = _push_children(node_box, lane_entry, entry, br, min(best.t, t_max),
                                          stack, stack_t, sp)
                if near != _DONE:
                    # Its entry is within best.t: taken without the check below.
                    entry = near
                    continue
            else:
                n_leaves += 1
                best, tests, hits = test_leaf(geo, acc, ray, entry, t_max, best,
                                              mode == ANY_HIT)
                n_tests += tests
                n_hits += hits
            # Pop the nearest pending entry that may still hold a closer hit.
            entry = _DONE
            if not (mode == ANY_HIT and best.prim >= 0):
                while sp > 0 and entry == _DONE:
                    sp -= 1
                    if stack_t[_unsigned(sp)] <= best.t:
                        entry = stack[_unsigned(sp)]
        tally(cnt, n_inner, n_leaves, n_tests, n_hits)
        return best
    return traverse


@njit(**JIT)
def _count_chunks(geo, ray, leaf_tris, prim_ids, k, n, k2, n2, t_max):
    """Hits of the ray among slots k .. k + n - 1 and k2 .. k2 + n2 - 1
    (n, n2 <= 4), tested at once (crossing_mask): a lane it cannot decide
    (an edge function exactly 0, a sphere) takes the scalar test, as does
    every hit of a ListingRay, whose test writes the hit down.  Counting
    tests 49 triangles a ray and hits 2.7 (random rays through a bumpy
    20k-triangle sphere): the scalar test of the ~5 a ray whose edge
    functions agree cost a quarter of the count when only the edge
    functions were in SIMD (docs/history.md)."""
    inside = ((1 << n) - 1) | (((1 << n2) - 1) << CHUNK)
    m = crossing_mask(leaf_tris, k, k2, ray, t_max)
    hits = m & inside
    todo = (m >> CROSSING_LANES) & inside
    n_hits = 0
    if records_hits(ray):
        todo |= hits
    else:
        n_hits += popcount(hits)
    while todo:    # not a loop over lanes: unrolled, it inlines test_prim 8 times
        lane = trailing_zeros(todo)
        slot = k + lane if lane < CHUNK else k2 + lane - CHUNK
        t, _, _ = test_prim(geo, ray, prim_ids[slot], t_max)
        n_hits += t < np.inf
        todo &= todo - 1
    return n_hits


@njit(**JIT)
def _next_chunk(queue, qn, i, k, end):
    """The next chunk of at most CHUNK slots of the queued leaves, from
    slot k of the current leaf (slots up to end) or the next entry, i:
    returns (i, k, end) moved past it, and its first slot and size (0
    when none is left)."""
    if k >= end and i < qn:
        k = queue[i] >> 32
        end = k + (queue[i] & 0xFFFFFFFF)
        i += 1
    n = min(end - k, CHUNK)
    return i, k + n, end, k, n


@njit(**JIT)
def _count_queue(geo, ray, leaf_tris, prim_ids, queue, qn, t_max):
    """Hits of the queued leaves: cut into chunks of at most CHUNK slots,
    tested two chunks at a time, so that two small leaves share one
    8-lane test (faster than a 4-lane test a leaf: docs/benchmarks.md,
    "BVH").  One call of the test, so it is compiled once.  Returns (hits,
    triangles tested): the count of tests taken from the chunks, not from
    a loop over the queue of its own."""
    n_hits = 0
    n_tests = 0
    zero = np.int64(0)     # not literal 0s: _next_chunk would be compiled twice
    i, k, end, k1, n1 = _next_chunk(queue, qn, zero, zero, zero)
    while n1 > 0:
        i, k, end, k2, n2 = _next_chunk(queue, qn, i, k, end)
        n_hits += _count_chunks(geo, ray, leaf_tris, prim_ids, k1, n1, k2, n2, t_max)
        n_tests += n1 + n2
        i, k, end, k1, n1 = _next_chunk(queue, qn, i, k, end)
    return n_hits, n_tests


@njit(**JIT)
def _sort_lanes(lanes, node, mask, stack, sp, queue, qn):
    """Push node's entered inner children and queue its entered leaves
    (as their lane words: first slot << 32 | count), without a branch:
    every lane is written to both, and each pointer advanced by the
    lane's bit.  Returns the two pointers."""
    base = node * WIDTH
    for lane in range(WIDTH):
        word = lanes[_unsigned(base + lane)]
        entered = (mask >> lane) & 1
        is_leaf = (word & 0xFFFFFFFF) > 0
        stack[_unsigned(sp)] = word >> 32
        sp += entered & (not is_leaf)
        queue[_unsigned(qn)] = word
        qn += entered & is_leaf
    return sp, qn


# A counting traversal's state between rounds: the next node (-1 when the
# tree is done), the stack and queue pointers, the ray's hits so far.
CountState = namedtuple("CountState", ["node", "sp", "qn", "hits"])
# The counts of every ray a loop has traced, added to the counter row once,
# at the end (per-ray counter updates were a visible share of a count).
Tallies = namedtuple("Tallies", ["n_inner", "n_leaves", "n_tests", "n_hits"])


@njit(**JIT)
def _count_start(acc, has_ray):
    """The state of a counting traversal about to begin (done at once on
    an empty tree or without a ray)."""
    return CountState(0 if has_ray and acc.node_box.shape[0] > 0 else -1, 0, 0, 0)


@njit(**JIT)
def _count_round(geo, acc, ray, br, t_max, stack, queue, s, t):
    """One round of counting: ROUND (2) nodes where the stack holds them
    (the second's loads and box tests do not wait on the first's; the same
    nodes and counts).  A node's entered inner children are pushed and its
    entered leaves queued without a branch.  The queued leaves are tested
    when the queue is nearly full or the tree is done, in one loop of
    predictable length, instead of a loop of 0 to 8 leaves a round.  The
    ratios behind ROUND and the queue: docs/benchmarks.md, "BVH".  Returns
    the state and the tallies t after the round."""
    node_box, lanes = acc.node_box, acc.lanes
    node, sp, qn = s.node, s.sp, s.qn
    # The round's other node, where the stack holds one (else it repeats
    # node, and its mask stays 0).
    two = sp > 0
    second = stack[_unsigned(sp - 1)] if two else node
    sp -= two
    mask, _ = child_boxes(node_box, node, br, t_max)
    mask2 = 0
    if two:   # only then: a masked test of the first node again cost short rays most
        mask2, _ = child_boxes(node_box, second, br, t_max)
    sp, qn = _sort_lanes(lanes, node, mask, stack, sp, queue, qn)
    sp, qn = _sort_lanes(lanes, second, mask2, stack, sp, queue, qn)
    node = -1
    if sp > 0:
        sp -= 1
        node = stack[_unsigned(sp)]
    hits, n_leaves, n_tests, n_hits = s.hits, t.n_leaves, t.n_tests, t.n_hits
    if qn > QUEUE_SIZE - ROUND * WIDTH or node < 0:
        new, tests = _count_queue(geo, ray, acc.leaf_tris, acc.prim_ids, queue, qn, t_max)
        hits += new
        n_hits += new
        n_tests += tests
        n_leaves += qn
        qn = 0
    return (CountState(node, sp, qn, hits),
            Tallies(t.n_inner + 1 + two, n_leaves, n_tests, n_hits))


@njit(**JIT)
def _count_traverse(geo, acc, ray, t_max, cnt):
    """Every hit of one ray (counting; a ListingRay writes its hits down),
    on a CountingBVH: nothing narrows the ray, so the order of visits does
    not matter.  A subtree of at most COUNT_LEAF primitives is one leaf
    here (accel/bvh/build.py, for_counting)."""
    stack = frame_array(COUNT_STACK_SIZE, np.int64)
    queue = frame_array(QUEUE_SIZE, np.int64)
    br = box_ray(acc, ray)
    s = _count_start(acc, np.bool_(True))    # not a literal: compiled once
    t = Tallies(0, 0, 0, 0)
    while s.node >= 0:
        s, t = _count_round(geo, acc, ray, br, t_max, stack, queue, s, t)
    tally(cnt, t.n_inner, t.n_leaves, t.n_tests, t.n_hits)
    return no_hit()


register(BVH, _traversal(CLOSEST), _traversal(ANY_HIT), None)
register(CountingBVH, None, None, _count_traverse)
