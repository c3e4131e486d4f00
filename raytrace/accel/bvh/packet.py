"""Packets of rays through the BVH: PACKET neighbouring rays of a batch
traverse the tree together (Wald, Slusallek, Benthin & Wagner 2001,
"Interactive Rendering with Coherent Ray Tracing", in the masked form:
each entry of the stack carries the mask of the rays that entered it).

A node's 4 child boxes are tested against all the packet's rays at once
(``simd_packets.packet_aabb4``, one <16 x float> a plane), and a child is
visited with the rays that enter it: for the closest hit nearest first by
the least of their entries, for any hit in lane order (most shadow rays
are blocked by nothing, so the order buys little and costs a sort).  A
leaf's triangles are tested against its rays at once where they share
their watertight axes (``simd_packets.packet_triangle``, <8 x double> for
each half of the packet some ray of which entered).  A leaf entered by
only one or two of the rays (deep in a big tree, where they have spread
apart: ALONE_MAX), and every leaf of a packet whose rays' axes differ
(shadow rays whose direction crosses a diagonal), is tested by each ray
alone, 4 triangles at a time, with the single-ray leaf test.  Neighbouring camera and shadow
rays enter nearly the same nodes, so a node's loads, box arithmetic and
branches serve many rays (docs/benchmarks.md, "BVH").

Each ray gets its own answer, bit for bit the single-ray traversal's
(accel/bvh/traverse.py): its box test is ray_aabb4's arithmetic, so it enters a
box exactly where its own test would with the same far bound; its
triangle tests are intersect._triangle's, operation for operation (a hit
takes its distance from the scalar test); and the closest is kept by the
same ``closer``.  The order of visits may differ, so the counters count
each ray's own visits and tests in the packet's order.

Rays go as a packet only as a whole PACKET of valid rays whose directions
have the same signs (so one near plane per axis serves all); otherwise,
and for a batch's last few rays, they take the single-ray path
(``closest_packet`` and ``occluded_packet`` return NOT_PACKED, having
written nothing).  Rays in every direction pay a sign check a packet, not
a load.  A packet whose rays share few of the nodes they visit (parallel
rays from scattered points, in any order) goes, but says so (SPARSE), and
the caller sends the rest of its chunk ray by ray.

Counting every hit (``count_packet``, on a CountingBVH) shares the box
tests, visiting every child some ray enters, in lane order; each ray
entering a leaf tests its triangles alone, 8 at a time (``_count_leaf``).
Camera rays, one call: 1.5-1.9x the two-ray stream's speed at 1k and 118k
triangles, none at 1M, where a packet's rays share only the top of the tree
(docs/benchmarks.md, "Counting coherent rays as packets").
"""
import math
from collections import namedtuple

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from raytrace.accel.bvh.layout import BVH, WIDTH
from raytrace.accel.bvh.simd import LEAF_LANES, leaf_hits
from raytrace.accel.bvh.simd_packets import HALF, packet_aabb4, packet_rays, packet_triangle
from raytrace.accel.bvh.traverse import (
    _DONE,
    BOX32_MARGIN,
    BOX32_RANGE,
    CHUNK,
    NEAR_LIMIT,
    STACK_SIZE,
    _count_chunks,
    _unsigned,
    leaf_slots,
    tally,
    test_leaf,
)
from raytrace.kernels.jit import JIT, STAGE
from raytrace.kernels.lowlevel import PACKET, frame_array, popcount
from raytrace.kernels.prims import (
    count_unbounded_hits,
    planes_closest,
    planes_occluded,
    test_prim,
)
from raytrace.kernels.query import (
    ANY_HIT,
    CLOSEST,
    NOT_PACKED,
    PACKED,
    SPARSE,
    register_packets,
)
from raytrace.kernels.ray import CrossingRay, Hit, Ray, closer, ray_ok

# A packet's rows, each in the frame of the function that traces it:
# fields (16 rows of PACKET float64: a Ray's float fields, rows 9-15 sx,
# sy, sz, okx, oky, okz, t_min as packet_triangle reads them), axes (kx,
# ky, kz rows), consts (box_ray's 12 float32 rows), t_far (each ray's box
# bound, float32), far (each ray's t_max), and the closest hits so far.
Packet = namedtuple("Packet", ["fields", "axes", "consts", "t_far", "far",
                               "best_t", "best_prim", "best_u", "best_v"])
# Frame rows (frame_array takes literal sizes).
_FIELD_ROWS = 16 * PACKET
_AXIS_ROWS = 3 * PACKET
_CONST_ROWS = 12 * PACKET
# A packet whose node visits served fewer rays than this on average sends
# the rest of its chunk ray by ray.  Parallel rays from points in random
# order share 1.5-1.7 rays a visit and their packets ran 1.45-2.3x slower
# than single rays; coherent packets share 4-14 (camera rays: 14.3 at 1k,
# 8.8 at 118k, 5.9 at 1M triangles; shadow rays 4.0 at 1M).  Shadow
# packets of 3 still beat single rays: with 3, shadow rays at 118k took
# 4.0-5.1 ms instead of 3.1-3.6 (docs/benchmarks.md, "Packets that share
# too few nodes").
SHARED_MIN = 2
# A half's rays in a packet's mask (packet_triangle tests a half at a time).
HALF_MASK = (1 << HALF) - 1


@njit(**JIT)
def _load(acc, origins, dirs, t_min, t_max, i0, pk):
    """Rays i0 .. i0 + PACKET - 1 into the packet's rows, with no hit yet:
    make_ray's and box_ray's values, computed for all the rays at once
    (``packet_rays``: one ray at a time, it was a large share of a shadow
    ray's cost).  Returns their shared near rows
    (nx, ny, nz), or nx = -1 where their near rows differ."""
    nx, ny, nz = packet_rays(origins, dirs, i0, acc.box_bound <= BOX32_RANGE, BOX32_RANGE,
                             NEAR_LIMIT, BOX32_MARGIN, pk.fields, pk.axes, pk.consts)
    for r in range(PACKET):
        pk.fields[15 * PACKET + r] = t_min[i0 + r]
        pk.far[r] = t_max[i0 + r]
        pk.t_far[r] = np.float32(t_max[i0 + r])
        pk.best_t[r] = np.inf
        pk.best_prim[r] = -1
        pk.best_u[r] = 0.0
        pk.best_v[r] = 0.0
    return nx, ny, nz


# Inlined by Numba, so its frame arrays are its caller's.
@njit(**STAGE)
def _loaded_packet(acc, origins, dirs, t_min, t_max, i0):
    """A packet's rows, in the caller's frame, holding rays i0 ..
    i0 + PACKET - 1 (_load), and their shared near rows (nx < 0: none)."""
    pk = Packet(frame_array(_FIELD_ROWS, np.float64), frame_array(_AXIS_ROWS, np.int64),
                frame_array(_CONST_ROWS, np.float32), frame_array(PACKET, np.float32),
                frame_array(PACKET, np.float64), frame_array(PACKET, np.float64),
                frame_array(PACKET, np.int64), frame_array(PACKET, np.float64),
                frame_array(PACKET, np.float64))
    nx, ny, nz = _load(acc, origins, dirs, t_min, t_max, i0, pk)
    return pk, nx, ny, nz


@njit(**JIT)
def _ray(pk, r):
    """Ray r of the packet, as make_ray made it."""
    fields, axes = pk.fields, pk.axes
    return Ray(fields[r], fields[PACKET + r], fields[2 * PACKET + r],
               fields[3 * PACKET + r], fields[4 * PACKET + r], fields[5 * PACKET + r],
               fields[6 * PACKET + r], fields[7 * PACKET + r], fields[8 * PACKET + r],
               axes[r], axes[PACKET + r], axes[2 * PACKET + r],
               fields[9 * PACKET + r], fields[10 * PACKET + r], fields[11 * PACKET + r],
               fields[12 * PACKET + r], fields[13 * PACKET + r], fields[14 * PACKET + r],
               fields[15 * PACKET + r])


@njit(**JIT)
def _push_children(lane_entry, node, masks, near, active, stack, stack_mask, stack_t, sp,
                   ordered):
    """The children of node that some ray of ``active`` enters (masks,
    near: packet_aabb4's): the one visited next is returned with its rays,
    not pushed (as in traverse._push_children), the others pushed with
    their rays and nearest entries, in the order a push of all then a pop
    would leave: with ``ordered`` (a compile-time constant) nearest on
    top, else in lane order.  Returns (sp, the next child's lane_entry
    word or _DONE, its rays).  Indices unsigned: sp never goes below 0."""
    base = sp
    next_entry = _DONE
    next_rays = 0
    next_d = np.inf
    for lane in range(WIDTH):
        rays = masks[lane] & active
        # Loaded whether or not the lane is entered: the load need not
        # wait for the box test (camera packets 3-6% faster at 118k and 1M).
        entry = lane_entry[_unsigned(node), lane]
        if rays:
            dl = near[lane] if ordered else 0.0
            if next_entry == _DONE:
                next_entry, next_rays, next_d = entry, rays, dl
                continue
            if not ordered or dl <= next_d:
                entry, next_entry = next_entry, entry
                rays, next_rays = next_rays, rays
                dl, next_d = next_d, dl
            k = sp
            while ordered and k > base and stack_t[_unsigned(k - 1)] < dl:
                stack[_unsigned(k)] = stack[_unsigned(k - 1)]
                stack_mask[_unsigned(k)] = stack_mask[_unsigned(k - 1)]
                stack_t[_unsigned(k)] = stack_t[_unsigned(k - 1)]
                k -= 1
            stack[_unsigned(k)] = entry
            stack_mask[_unsigned(k)] = rays
            stack_t[_unsigned(k)] = dl
            sp += 1
    return sp, next_entry, next_rays


@njit(**JIT)
def _counting_ray(pk, r):
    """Ray r of the packet as make_crossing_ray made it (counting's test)."""
    return CrossingRay(*_ray(pk, r))


# count_packet and its traversal are inlined by Numba into their one caller
# (count_stream._count_packets), so they add no level of calls.
@njit(**STAGE)
def _count_traversal(geo, acc, pk, nx, ny, nz, counts, cnt):
    """Every hit of the packet's rays on a CountingBVH, added to their
    rows of ``counts``: the single-ray count's visits (accel/bvh/traverse.py,
    _count_round), ray by ray.  Nothing narrows a ray, so every child some
    ray enters is visited with those rays, in lane order; a lane is a leaf
    where its ``lanes`` word counts slots (a small subtree counts as one
    leaf, as it does for one ray), and each ray that entered it tests its
    slots (_count_leaf).  So each ray's hits and counters are its own.
    Returns _verdict's on its node visits."""
    consts, t_far, far = pk.consts, pk.t_far, pk.far
    node_box, lanes = acc.node_box, acc.lanes
    if node_box.shape[0] == 0:
        return PACKED
    stack = frame_array(STACK_SIZE, np.int64)
    stack_mask = frame_array(STACK_SIZE, np.int64)
    # int64s, not literal 0s: tally was compiled for the literals too.
    n_inner = n_leaves = n_tests = n_hits = np.int64(0)
    visits = 0
    stack[0] = 0
    stack_mask[0] = (1 << PACKET) - 1
    sp = np.int64(1)
    while sp > 0:
        sp -= 1
        node = stack[_unsigned(sp)]
        rays = stack_mask[_unsigned(sp)]
        n_inner += popcount(rays)
        visits += 1
        masks, _ = packet_aabb4(node_box, node, nx, ny, nz, consts, t_far)
        for lane in range(WIDTH):
            entered = masks[lane] & rays
            if entered == 0:
                continue
            word = lanes[node * WIDTH + lane]
            start, size = word >> 32, word & 0xFFFFFFFF
            if size == 0:
                stack[_unsigned(sp)] = start
                stack_mask[_unsigned(sp)] = entered
                sp += 1
                continue
            n_leaves += popcount(entered)
            n_tests += popcount(entered) * size
            todo = entered
            while todo:
                r = trailing_zeros(todo)
                todo &= todo - 1
                hits = _count_leaf(geo, acc, _counting_ray(pk, r), start, size, far[r])
                counts[r] += hits
                n_hits += hits
    tally(cnt, n_inner, n_leaves, n_tests, n_hits)
    return _verdict(n_inner, visits)


@njit(**JIT)
def _count_leaf(geo, acc, ray, start, size, t_max):
    """The hits of one ray among leaf slots start .. start + size - 1,
    CHUNK slots at a time, two chunks a test (traverse._count_chunks, the
    single-ray count's 8-triangle crossing test).  A packet's leaf is
    entered by a few of its rays, often 1 to 4 at 118k triangles, and a
    triangle tested against all 16 lanes cost as much as 8 triangles
    against one ray: so each ray entering a leaf tests its triangles
    alone."""
    hits = 0
    k = start
    end = start + size
    while k < end:
        n = min(CHUNK, end - k)
        k2 = k + n
        n2 = min(CHUNK, end - k2)
        # An empty second chunk reads the first's columns (masked out), not
        # columns past the copy's end.
        hits += _count_chunks(geo, ray, acc.leaf_tris, acc.prim_ids, k, n, k2 if n2 else k, n2,
                              t_max)
        k = k2 + n2
    return hits


@njit(**STAGE)
def count_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, out, cnt):
    """out[i] = the hits of ray i (count_hits of a CrossingRay) for rays
    i0 .. i0 + m - 1, if they go as a packet (a CountingBVH); returns
    NOT_PACKED, PACKED or SPARSE (query.py)."""
    if not _packet(origins, dirs, t_min, t_max, i0, m):
        return NOT_PACKED
    pk, nx, ny, nz = _loaded_packet(acc, origins, dirs, t_min, t_max, i0)
    if nx < 0:
        return NOT_PACKED
    counts = pk.best_prim     # a packet's row of int64s, unused by a count
    for r in range(PACKET):
        counts[r] = 0
    verdict = _count_traversal(geo, acc, pk, nx, ny, nz, counts, cnt)
    unbounded = geo.pl_point.shape[0] + geo.sph_center.shape[0] > 0
    for r in range(PACKET):
        out[i0 + r] = counts[r] + (count_unbounded_hits(geo, _counting_ray(pk, r), pk.far[r],
                                                        cnt) if unbounded else 0)
    return verdict


# A leaf entered by at most this many of a packet's rays is tested ray by
# ray, 4 slots at a time (traverse.test_leaf), not triangle by triangle
# for all PACKET lanes.  Kernel alone, one thread, 640x480 camera and
# shadow rays: at 1k triangles no row changes; at 118k shadow rays 5-16%
# faster, at 1M camera rays 10% and shadow rays 12-18%.  4 cost 5-15% at
# 1k; "fewer rays than the leaf has triangles" gained half as much
# (docs/benchmarks.md, "Leaves tested 4 triangles at a time").
ALONE_MAX = 2


@njit(**JIT)
def _rays_alone(geo, acc, pk, rays, alive, entry, first):
    """Each ray of ``rays`` against the leaf whose lane_entry word is
    ``entry`` on its own (traverse.test_leaf), its best_* rows and t_far
    updated; with ``first`` (any hit) a ray stops at its first hit and
    leaves ``alive``.
    Returns alive, and the tests and hits to count: each ray's own, as
    the packet's triangle-by-triangle loop counts them."""
    n_tests = 0
    n_hits = 0
    todo = rays
    while todo:
        r = trailing_zeros(todo)
        todo &= todo - 1
        ray = _ray(pk, r)
        best = Hit(pk.best_t[r], pk.best_prim[r], pk.best_u[r], pk.best_v[r])
        best, tests, hits = test_leaf(geo, acc, ray, entry, pk.far[r], best, first)
        n_tests += tests
        n_hits += hits
        if first:
            if best.prim >= 0:
                alive &= ~(1 << r)
        elif best.prim != pk.best_prim[r] or best.t != pk.best_t[r]:
            pk.best_t[r] = best.t
            pk.best_prim[r] = best.prim
            pk.best_u[r] = best.u
            pk.best_v[r] = best.v
            pk.t_far[r] = np.float32(min(best.t, pk.far[r]))
    return alive, n_tests, n_hits


# One caller, inlined by Numba: no library of its own (kernels/jit.py).
@njit(**STAGE)
def _slot_hit(geo, acc, ray, k, p, t_max):
    """The scalar test's (t, b1, b2) for slot k (primitive p), from the
    one-ray leaf test's first lane (simd.leaf_hits: each lane the scalar
    test's operations) on the leaf's columns, which the packet test has
    just loaded, not from the geometry's rows through the id; a lane it
    cannot decide (a NaN determinant: a sphere's slot) takes the scalar
    test, as traverse._test_slots does.  For closest hits only, whose
    hits come here: an any-hit packet's rays stop at a hit, only a
    sphere's slot takes a scalar test there, and this second copy of the
    leaf test cost the any-hit kernel's first compile 0.2 s."""
    m, ts, us, vs = leaf_hits(acc.leaf_tris, k, ray, t_max)
    if m & 1:
        return ts[0], us[0], vs[0]
    if (m >> LEAF_LANES) & 1:
        return test_prim(geo, ray, p, t_max)
    return np.inf, 0.0, 0.0


@njit(**STAGE)
def _prim_hit(geo, acc, ray, k, p, t_max):
    """_slot_hit's answer from the scalar test on the geometry (test_prim),
    for any-hit packets."""
    return test_prim(geo, ray, p, t_max)


def _packet_traversal(mode):
    hit_test = _slot_hit if mode == CLOSEST else _prim_hit
    # One caller, its query: inlined by Numba, so it has no library of its
    # own, optimised and emitted before the query's optimises it again
    # (0.2-0.3 s of each packet kernel's cold compile; kernels/jit.py).
    @njit(**STAGE)
    def traverse(geo, acc, pk, nx, ny, nz, alive, cnt):
        """The packet's rays of ``alive`` through the tree; returns the rays
        still without a hit (any hit), or alive unchanged (closest: the
        packet's best_* rows hold each ray's closest hit), and _verdict's
        on its node visits."""
        fields, axes, consts, t_far, far = pk.fields, pk.axes, pk.consts, pk.t_far, pk.far
        best_t, best_p, best_u, best_v = pk.best_t, pk.best_prim, pk.best_u, pk.best_v
        node_box, lane_entry, prim_ids = acc.node_box, acc.lane_entry, acc.prim_ids
        if node_box.shape[0] == 0:
            return alive, PACKED
        stack = frame_array(STACK_SIZE, np.int64)
        stack_mask = frame_array(STACK_SIZE, np.int64)
        stack_t = frame_array(STACK_SIZE, np.float64)
        n_tris = geo.tri_v0.shape[0]
        shared_axes = _shared_axes(axes)
        # int64s, not literal 0s: tally was compiled for the literals too.
        n_inner = n_leaves = n_tests = n_hits = np.int64(0)
        visits = 0
        # int64s, not literal 0s: a call given a literal is compiled again
        # for it (as in traverse.py).
        entry = np.int64(0)
        rays = alive
        sp = np.int64(0)
        while entry != _DONE:
            if entry >= 0:
                n_inner += popcount(rays)
                visits += 1
                masks, near = packet_aabb4(node_box, entry, nx, ny, nz, consts, t_far)
                sp, child, child_rays = _push_children(lane_entry, entry, masks, near, rays,
                                                       stack, stack_mask, stack_t, sp,
                                                       mode == CLOSEST)
                if child != _DONE:
                    entry = child
                    rays = child_rays
                    if mode == ANY_HIT:
                        rays &= alive
                    continue
            elif popcount(rays) <= ALONE_MAX or not shared_axes:
                # Rays whose axes differ took the scalar test triangle by
                # triangle; alone, 4 at a time (shadow rays 10% faster).
                n_leaves += popcount(rays)
                alive, tests, hits = _rays_alone(geo, acc, pk, rays, alive, entry, mode == ANY_HIT)
                n_tests += tests
                n_hits += hits
            else:
                n_leaves += popcount(rays)
                k, end = leaf_slots(entry)
                while k < end and rays != 0:
                    p = prim_ids[_unsigned(k)]
                    todo = rays
                    if p < n_tris:
                        # All the rays at once, a half of the packet at a
                        # time where some of its rays are here; the scalar
                        # test only for the hits' distances.
                        n_tests += popcount(rays)
                        hits = 0
                        for half in range(2):
                            if (rays >> (HALF * half)) & HALF_MASK:
                                hits |= packet_triangle(acc.leaf_tris, k, axes[0], axes[PACKET],
                                                        axes[2 * PACKET], fields, far, half)
                        hits &= rays
                        n_hits += popcount(hits)
                        todo = 0
                        if mode == ANY_HIT:
                            alive &= ~hits
                            rays &= ~hits
                        else:
                            todo = hits
                            n_tests -= popcount(hits)
                            n_hits -= popcount(hits)
                    while todo:
                        r = trailing_zeros(todo)
                        todo &= todo - 1
                        n_tests += 1
                        t, u, v = hit_test(geo, acc, _ray(pk, r), k, p, far[r])
                        if t < np.inf:
                            n_hits += 1
                            if mode == ANY_HIT:
                                alive &= ~(1 << r)
                                rays &= ~(1 << r)
                            elif closer(t, p, Hit(best_t[r], best_p[r], best_u[r], best_v[r])):
                                best_t[r] = t
                                best_p[r] = p
                                best_u[r] = u
                                best_v[r] = v
                                t_far[r] = np.float32(min(t, far[r]))
                    k += 1
            # Pop the nearest pending entry some ray may still need.
            entry = _DONE
            while sp > 0 and entry == _DONE:
                sp -= 1
                rays = stack_mask[_unsigned(sp)]
                if mode == ANY_HIT:
                    rays &= alive
                else:
                    rays &= _within(stack_t[_unsigned(sp)], best_t, rays)
                if rays:
                    entry = stack[_unsigned(sp)]
        tally(cnt, n_inner, n_leaves, n_tests, n_hits)
        return alive, _verdict(n_inner, visits)
    return traverse


@njit(**JIT)
def _verdict(ray_visits, visits):
    """PACKED, or SPARSE where the packet's node visits served fewer than
    SHARED_MIN of its rays each on average."""
    return SPARSE if ray_visits < SHARED_MIN * visits else PACKED


@njit(**JIT)
def _shared_axes(axes):
    """Whether the packet's rays share their watertight axes kx, ky, kz
    (packet_triangle tests them together only then; otherwise each ray
    tests a leaf alone)."""
    same = True
    for r in range(1, PACKET):
        same &= ((axes[r] == axes[0]) & (axes[PACKET + r] == axes[PACKET])
                 & (axes[2 * PACKET + r] == axes[2 * PACKET]))
    return same


@njit(**JIT)
def _within(entry_t, best_t, rays):
    """The rays of ``rays`` whose closest hit so far is not nearer than
    entry_t (the single-ray loop's skip, ray by ray)."""
    keep = 0
    todo = rays
    while todo:
        r = trailing_zeros(todo)
        todo &= todo - 1
        keep |= (entry_t <= best_t[r]) << r
    return keep


@njit(**JIT)
def _negative(x):
    """Whether x's sign bit is set (-0.0 too: its inverse is -inf)."""
    return math.copysign(1.0, x) < 0.0


@njit(**JIT)
def _packet(origins, dirs, t_min, t_max, i0, m):
    """Whether rays i0 .. i0 + m - 1 may go as a packet: a whole packet,
    every ray valid (a bad one is the single-ray path's to report), and
    the signs of their directions alike, so their near planes are too,
    unless a ray lies beyond the float32 test's range (_load decides).
    Checked before _load: rays in every direction cost this, not a load."""
    if m < PACKET:
        return False
    # The signs first, stopping at the first ray whose signs differ: rays
    # in random directions leave at the second or third ray, not after
    # checking all of them (5 ns a ray of a box ray's 200, one thread).
    sx, sy, sz = _negative(dirs[i0, 0]), _negative(dirs[i0, 1]), _negative(dirs[i0, 2])
    for i in range(i0 + 1, i0 + m):
        if (_negative(dirs[i, 0]) != sx) | (_negative(dirs[i, 1]) != sy) \
                | (_negative(dirs[i, 2]) != sz):
            return False
    # Unsigned indices: with Numba's wraparound of a negative index, LLVM
    # vectorised this loop with gathers (24 in the closest-hit block, 48 in
    # the any-hit one); without it, with loads and shuffles.
    ok = True
    for r in range(PACKET):
        ok &= ray_ok(origins, dirs, t_min, t_max, _unsigned(i0 + r))
    return ok


def _packet_query(mode):
    traverse = _packet_traversal(mode)

    def query(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
        """Rays i0 .. i0 + m - 1 as a packet, if they can go as one, their
        answers written into ``outs`` (closest: the t, prim, u and v
        arrays; any hit: the blocked flags' array); returns NOT_PACKED,
        PACKED or SPARSE (query.py)."""
        if not _packet(origins, dirs, t_min, t_max, i0, m):
            return NOT_PACKED
        pk, nx, ny, nz = _loaded_packet(acc, origins, dirs, t_min, t_max, i0)
        if nx < 0:
            return NOT_PACKED
        verdict = PACKED
        if mode == CLOSEST:
            _, verdict = traverse(geo, acc, pk, nx, ny, nz, np.int64((1 << PACKET) - 1), cnt)
            for r in range(PACKET):
                hit = planes_closest(geo, _ray(pk, r), pk.far[r],
                                     Hit(pk.best_t[r], pk.best_prim[r], pk.best_u[r],
                                         pk.best_v[r]), cnt)
                outs[0][i0 + r] = hit.t
                outs[1][i0 + r] = hit.prim
                outs[2][i0 + r] = hit.u
                outs[3][i0 + r] = hit.v
        else:
            # Planes first, as the single-ray path: a blocked ray leaves
            # the packet.
            alive = np.int64(0)    # not a literal 0: traverse was compiled twice
            for r in range(PACKET):
                alive |= (not planes_occluded(geo, _ray(pk, r), pk.far[r], cnt)) << r
            if alive:
                alive, verdict = traverse(geo, acc, pk, nx, ny, nz, alive, cnt)
            for r in range(PACKET):
                outs[i0 + r] = not ((alive >> r) & 1)
        return verdict
    return query


# Not decorated: kernels/query.py's closest_packet and occluded_packet
# compile them as their own implementations for the BVH's layout, so no
# wrapper adds a level of calls.  Numba compiles an @overload's
# implementation in full even where it is inlined, and each level
# optimises and emits again all the packet code below it: a wrapper level
# cost a quarter second a query (docs/benchmarks.md, "Camera rays through
# packets").
closest_packet = _packet_query(CLOSEST)
closest_packet.__doc__ = """Closest hits of rays i0 .. i0 + m - 1 as cast_closest writes them
(outs: its t, prim, u and v arrays), if they go as a packet; returns
NOT_PACKED, PACKED or SPARSE (query.py)."""
occluded_packet = _packet_query(ANY_HIT)
occluded_packet.__doc__ = """Whether rays i0 .. i0 + m - 1 are blocked, as cast_occluded writes
it (outs: its flags' array), if they go as a packet; returns NOT_PACKED,
PACKED or SPARSE (query.py)."""

register_packets(BVH, closest_packet, occluded_packet)
