"""Counting every hit of a batch of rays on the BVH (query.count_rays's
stream for the CountingBVH layout): coherent rays a packet at a time
(packet.count_packet), the others two in flight (count_stream).

Each thread takes chunks of rays by ticket.  A chunk's rays go as packets
first where they can (a whole packet of valid rays whose directions share
their signs, as the closest-hit packets), their counts written; the
two-ray stream counts the rest, passing over the packets that went (a
bit each).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from raytrace.accel.bvh.layout import CountingBVH
from raytrace.accel.bvh.packet import count_packet
from raytrace.accel.bvh.traverse import (
    COUNT_STACK_SIZE,
    QUEUE_SIZE,
    Tallies,
    _count_round,
    _count_start,
    box_ray,
    tally,
)
from raytrace.kernels.counters import BAD_RAYS
from raytrace.kernels.jit import JIT, STAGE
from raytrace.kernels.lowlevel import PACKET, frame_array, take_ticket
from raytrace.kernels.prims import count_unbounded_hits
from raytrace.kernels.query import NOT_PACKED, SPARSE, register_count_stream
from raytrace.kernels.ray import WIDE, make_crossing_ray, ray_ok, widen_rays


@njit(**JIT)
def _next_good_ray(job, i, start, end, packed, cnt):
    """The first ray from i on, below end, that no packet of the chunk
    from start counted (bit k of ``packed``: packet k went) and that
    ray_ok passes; end when none is left.  Each bad ray passed over gets 0
    and is counted in cnt[BAD_RAYS]."""
    while i < end:
        k = (i - start) // PACKET
        if k < _PACKETS_A_CHUNK and (packed >> k) & 1:
            i = start + (k + 1) * PACKET
        elif ray_ok(job.origins, job.dirs, job.t_min, job.t_max, i):
            break
        else:
            cnt[BAD_RAYS] += 1
            job.out[i] = 0
            i += 1
    return i


# The packets of a chunk _count_packets tries: one bit each in a word.
_PACKETS_A_CHUNK = 64


# Inlined by Numba into count_stream, its one caller, with the packet
# code below it: compiled as count_stream's, not as a level of its own
# (each level optimises all the code below it again: docs/design.md).
@njit(**STAGE)
def _count_packets(job, start, end, cnt):
    """The rays of the chunk start .. end - 1 that go as a packet counted
    (packet.count_packet: camera rays and other coherent ones, whose nodes
    a packet shares), up to _PACKETS_A_CHUNK packets, and none after one
    whose rays shared too few nodes (SPARSE); returns the mask of the
    packets that went.  The two-ray stream counts the rest."""
    packed = np.int64(0)
    m = np.int64(PACKET)     # not a literal: count_packet's callees would compile again
    for k in range(min(_PACKETS_A_CHUNK, (end - start) // PACKET)):
        i0 = start + k * PACKET
        went = count_packet(job.geo, job.acc, job.origins, job.dirs, job.t_min, job.t_max, i0, m,
                            job.out, cnt)
        if went == NOT_PACKED:
            continue
        packed |= np.int64(1) << k
        if went == SPARSE:      # its rays shared few nodes: the chunk's rest alone
            break
    return packed


@njit(**JIT)
def _crossing_ray(origins, dirs, t_min, t_max, i, last):
    """Ray i as a CrossingRay and its t_max; past ``last``, the chunk's
    last ray (a slot with no ray left still holds one, never traced), the
    last one's: a float32 call's rows past the chunk are not the thread's
    (ray.widen_rays)."""
    i = min(i, last)
    ray = make_crossing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                            dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i])
    return ray, t_max[i]


# What both of count_stream's slots read and write: the scene, its
# counting tree, the rays, the counts, counters and ticket clock, the chunk
# size, and whether the scene has hits no tree holds.
CountJob = namedtuple("CountJob", ["geo", "acc", "origins", "dirs", "t_min", "t_max", "out", "cnt",
                                   "clock", "chunk", "unbounded"])
# The chunk of rays the stream is on: rays start .. end - 1, and the
# packets of it that went (_count_packets: bit k, packet k).
Span = namedtuple("Span", ["start", "end", "packed"])


@njit(**JIT)
def _count_slot(job, span, i, ray, tm, br, s, t, stack, queue, after):
    """A round of the ray in one of count_stream's slots (job: the stream's
    CountJob) in ``span`` (a Span of a chunk): ray i (below its end), its t_max tm,
    BoxRay br and state s; t the stream's tallies.  When its traversal is
    done its count is written, with the hits no tree holds if the scene
    has them (``unbounded``: planes, spheres' far roots), and the slot
    takes the chunk's next good ray from ``after`` on (_next_good_ray).
    Returns (i, ray, tm, br, s, t, after) for the next round."""
    geo, acc, cnt = job.geo, job.acc, job.cnt
    origins, dirs, t_min, t_max = job.origins, job.dirs, job.t_min, job.t_max
    if s.node >= 0:
        s, t = _count_round(geo, acc, ray, br, tm, stack, queue, s, t)
    if s.node < 0:
        job.out[i] = s.hits + (count_unbounded_hits(geo, ray, tm, cnt) if job.unbounded else 0)
        i = _next_good_ray(job, after, span.start, span.end, span.packed, cnt)
        after = i + 1
        ray, tm = _crossing_ray(origins, dirs, t_min, t_max, i, span.end - 1)
        br = box_ray(acc, ray)
        s = _count_start(acc, i < span.end)
    return i, ray, tm, br, s, t, after


def count_stream(geo, acc, origins, dirs, t_min, t_max, narrow, out, cnt, clock, chunk):
    """query.count_rays on a CountingBVH.  Rays come a chunk at a time by
    ticket, as in kernels/cast.py.  A chunk's rays go as packets where
    they can (_count_packets); the rest two in flight, a round of one and
    then a round of the other, each slot taking the chunk's next ray when
    its own is done.  A round's box tests and pushes wait on the loads
    before them, and one ray's rounds on each other: the other ray's round
    fills those waits (two in flight: docs/benchmarks.md, "BVH").

    Not decorated: query.count_rays compiles it as its own implementation
    for the layout, so that no wrapper adds a level of calls (each level
    compiles all the code below it again: docs/design.md, "Compile time")."""
    n = t_min.shape[0]
    stack_a = frame_array(COUNT_STACK_SIZE, np.int64)
    queue_a = frame_array(QUEUE_SIZE, np.int64)
    stack_b = frame_array(COUNT_STACK_SIZE, np.int64)
    queue_b = frame_array(QUEUE_SIZE, np.int64)
    wide = frame_array(WIDE, np.float64), frame_array(WIDE, np.float64)
    unbounded = geo.pl_point.shape[0] + geo.sph_center.shape[0] > 0
    t = Tallies(0, 0, 0, 0)
    c = take_ticket(clock)
    while c * chunk < n:
        start, end = c * chunk, min(n, (c + 1) * chunk)
        o_rows, d_rows = widen_rays(narrow, origins, dirs, start, end, wide)
        job = CountJob(geo, acc, o_rows, d_rows, t_min, t_max, out, cnt, clock, chunk, unbounded)
        packed = _count_packets(job, start, end, cnt)
        span = Span(start, end, packed)
        # A slot past the chunk's end still holds a ray (the last one's),
        # never traced.
        ia = _next_good_ray(job, start, start, end, packed, cnt)
        ib = _next_good_ray(job, ia + 1, start, end, packed, cnt)
        after = ib + 1
        ray_a, tm_a = _crossing_ray(o_rows, d_rows, t_min, t_max, ia, end - 1)
        ray_b, tm_b = _crossing_ray(o_rows, d_rows, t_min, t_max, ib, end - 1)
        br_a = box_ray(acc, ray_a)
        br_b = box_ray(acc, ray_b)
        sa = _count_start(acc, ia < end)
        sb = _count_start(acc, ib < end)
        while ia < end or ib < end:
            if ia < end:
                ia, ray_a, tm_a, br_a, sa, t, after = _count_slot(
                    job, span, ia, ray_a, tm_a, br_a, sa, t, stack_a, queue_a, after)
            if ib < end:
                ib, ray_b, tm_b, br_b, sb, t, after = _count_slot(
                    job, span, ib, ray_b, tm_b, br_b, sb, t, stack_b, queue_b, after)
        c = take_ticket(clock)
    tally(cnt, t.n_inner, t.n_leaves, t.n_tests, t.n_hits)


register_count_stream(CountingBVH, count_stream)
