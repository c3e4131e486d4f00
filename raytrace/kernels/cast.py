"""Batch ray casting for arbitrary rays: the Python API's kernels and the
reference the tests compare structures with.

Rays go out in chunks of CHUNK consecutive rays.  Each counter block b (a
row of cnt_rows, so threads never share a counter and the kernels, compiled
without the NRT, allocate nothing; one per thread, cast/rayscene.py) takes the
next chunk nobody has taken, by a ticket from ``clock`` (a one-element
array, 0 at the call: lowlevel.take_ticket), until none is left.  So the
threads sweep the rays once, together, neighbouring chunks at about the
same time (the cache reuse between neighbouring rays), and a thread slowed
by another process on its core takes fewer chunks instead of holding up
the call, as a fixed share each would.  Chunks of 1,024 rays rather than
64 keep two threads' speed-up steady from call to call.  The numbers
behind both choices: docs/benchmarks.md, "Kernels".

A call of one chunk or less (one counter row) runs in the calling thread:
waking a worker (threads.py) costs more than thousands of shadow rays.  A
thread's loop (``*_block``) is compiled as a function of its own
(``BLOCK``), called from Python on each thread.

Closest and any hit take the rays PACKET at a time: a structure with
packet traversals (the BVH, accel/bvh/packet.py) traces neighbouring rays
together where they can go so, each ray getting the answer it gets alone;
the rest, and every other structure, go one ray at a time, as does the
rest of a chunk after a packet whose rays shared too few nodes (SPARSE).
Calls of fewer than PACKET_MIN rays go one ray at a time through kernels
compiled without the packet code.

Rays are checked as they are read (``ray_ok``): a bad one is not traced,
its output is a miss, and it is counted in column BAD_RAYS of the counter
rows, after the declared counters, so the Python layer names the problem
after the call; a separate pass over the rays would be a sizeable share of
a call.

Each kernel is compiled once per structure (query.py), on first use.  The
ray queries' blocks take the geometry and the structure (or its counting
layout) packed (``ray_scene``, packed.py): their wrappers unbox one word
for them, not some thirty arrays, which cost a cold compile 0.1-0.2 s a
block.
"""
import functools
import threading

import numpy as np
from numba import njit

from raytrace.kernels.counters import BAD_RAYS, N_COUNTERS
from raytrace.kernels.entry import entry_of
from raytrace.kernels.jit import BLOCK, JIT
from raytrace.kernels.lowlevel import PACKET, frame_array, take_rows, take_ticket
from raytrace.kernels.packed import Packed, unpack
from raytrace.kernels.query import (
    NOT_PACKED,
    PACKED,
    closest_hit,
    closest_packet,
    count_rays,
    has_packets,
    list_hits,
    occluded,
    occluded_packet,
)
from raytrace.kernels.ray import (
    CHUNK,
    WIDE,
    make_listing_ray,
    no_hit,
    ray_at,
    ray_ok,
    widen_rays,
)
from raytrace.kernels.threads import run_on_threads, run_rows

COLUMNS = N_COUNTERS + 1   # BAD_RAYS last


def _closest_kernel(packets):
    """A thread's share of cast_closest, tracing packets where the rays
    can go as one (``packets``) or every ray alone.  rays: (origins,
    dirs, t_min, t_max); narrow: empty, or the call's float32 origins and
    directions (rays' are then empty), widened a chunk at a time
    (ray.widen_rays)."""
    @njit(**BLOCK)
    def block(scene, rays, narrow, outs, cnt, rows, clock):
        geo, acc = unpack(scene)
        _, _, t_min, t_max = rays
        out_t, out_prim, out_u, out_v = outs
        n = t_min.shape[0]
        per_ray = rows.shape[0] > 0
        n_chunks = (n + CHUNK - 1) // CHUNK
        wide = frame_array(WIDE, np.float64), frame_array(WIDE, np.float64)
        c = take_ticket(clock)
        while c < n_chunks:
            end = min(n, (c + 1) * CHUNK)
            origins, dirs = widen_rays(narrow, rays[0], rays[1], c * CHUNK, end, wide)
            try_packets = not per_ray
            for i0 in range(c * CHUNK, end, PACKET):
                m = min(PACKET, end - i0)
                # ``packets`` first: a compile-time False prunes the branch, so the
                # one-ray kernel compiles no packet code.
                if packets and try_packets:
                    went = closest_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, outs,
                                          cnt[0])
                    if went != NOT_PACKED:
                        try_packets = went == PACKED    # not SPARSE: the chunk's rest alone
                        continue
                for i in range(i0, i0 + m):
                    row = cnt[rows[i]] if per_ray else cnt[0]
                    if ray_ok(origins, dirs, t_min, t_max, i):
                        hit = closest_hit(geo, acc, ray_at(origins, dirs, t_min, i), t_max[i], row)
                    else:
                        row[BAD_RAYS] += 1
                        hit = no_hit()
                    out_t[i] = hit.t
                    out_prim[i] = hit.prim
                    out_u[i] = hit.u
                    out_v[i] = hit.v
            c = take_ticket(clock)
    return block


def _occluded_kernel(packets):
    """A thread's share of cast_occluded, as _closest_kernel's."""
    @njit(**BLOCK)
    def block(scene, rays, narrow, out_hit, cnt, rows, clock):
        geo, acc = unpack(scene)
        _, _, t_min, t_max = rays
        n = t_min.shape[0]
        per_ray = rows.shape[0] > 0
        n_chunks = (n + CHUNK - 1) // CHUNK
        wide = frame_array(WIDE, np.float64), frame_array(WIDE, np.float64)
        c = take_ticket(clock)
        while c < n_chunks:
            end = min(n, (c + 1) * CHUNK)
            origins, dirs = widen_rays(narrow, rays[0], rays[1], c * CHUNK, end, wide)
            try_packets = not per_ray
            for i0 in range(c * CHUNK, end, PACKET):
                m = min(PACKET, end - i0)
                # ``packets`` first: a compile-time False prunes the branch, so the
                # one-ray kernel compiles no packet code.
                if packets and try_packets:
                    went = occluded_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, out_hit,
                                           cnt[0])
                    if went != NOT_PACKED:
                        try_packets = went == PACKED
                        continue
                for i in range(i0, i0 + m):
                    row = cnt[rows[i]] if per_ray else cnt[0]
                    if ray_ok(origins, dirs, t_min, t_max, i):
                        out_hit[i] = occluded(geo, acc, ray_at(origins, dirs, t_min, i), t_max[i],
                                              row)
                    else:
                        row[BAD_RAYS] += 1
                        out_hit[i] = False
            c = take_ticket(clock)
    return block


_closest_block = _closest_kernel(True)
_occluded_block = _occluded_kernel(True)
# Calls of fewer rays than this go one ray at a time: a few packets gain
# nothing a call, and such a call (a program's first, often) then
# compiles no packet code, the larger share of a structure's compile.
PACKET_MIN = 4 * PACKET
_closest_single = _closest_kernel(False)
_occluded_single = _occluded_kernel(False)


def closest_block(acc, n_rays):
    """The closest-hit kernel a call of ``n_rays`` rays on layout ``acc``
    runs: the packet kernel for PACKET_MIN rays or more on a structure
    with packet traversals.  Any other structure's packet kernel would be
    the one-ray kernel again, a second compile of it."""
    return _closest_block if n_rays >= PACKET_MIN and has_packets(acc) else _closest_single


def occluded_block(acc, n_rays):
    """closest_block's choice for the any-hit kernel."""
    return _occluded_block if n_rays >= PACKET_MIN and has_packets(acc) else _occluded_single


def run_blocks(block, args, cnt_rows, clock, entries=None):
    """run_rows for the closest and any-hit blocks: a thread's rays all
    count into its row of cnt_rows (no per-ray rows); through the block's
    compiled entry point kept in ``entries`` if given (entry.py's
    entry_of): Numba's dispatcher types every argument at every call,
    60-80 us a thread for these blocks, which was most of a call of 2,048
    rays (docs/benchmarks.md, "A query's threads through the compiled
    entry").  So ``entries`` must serve arguments of one set of types
    only: one prepared scene's, with the rays as kernel_rays makes them,
    or one render thread's buffers."""
    # The entry looked up here, not through entry_of: a call of one ray is
    # some 9 us, and each level of Python calls a share of it.
    call = block if entries is None else entries.get(block) or entry_of(block, entries)
    if len(cnt_rows) == 1:      # one thread's: called at once, as a call of a ray is
        call(*args, cnt_rows, _ONE_ROW, clock)
        return
    run_on_threads([functools.partial(call, *args, cnt_rows[b:b + 1], _ONE_ROW, clock)
                    for b in range(cnt_rows.shape[0])])


_ONE_ROW = np.empty(0, np.int64)
_NO_NARROW = np.empty((0, 3), np.float32)
FLOAT64_RAYS = (_NO_NARROW, _NO_NARROW)     # a call's ``narrow``: its rays are float64
_NO_WIDE = np.empty((0, 3))                 # a float32 call's float64 rows: none
_FLOAT32 = np.dtype(np.float32)     # compared faster than the type


def kernel_rays(origins, dirs, t_min, t_max):
    """(rays, narrow) as the ray queries' blocks take them.
    origins, dirs: C-contiguous, aligned and writeable (n, 3) float64
    arrays, or float32 ones (or the same (n, 6) float32 rows twice), which
    each thread widens a chunk at a time (ray.widen_rays).  The blocks
    take the number of rays from t_min."""
    if origins.dtype != _FLOAT32:
        return (origins, dirs, t_min, t_max), FLOAT64_RAYS
    return (_NO_WIDE, _NO_WIDE, t_min, t_max), (origins, dirs)


# Scratch (n, 3) float64 rows each thread keeps for its next call (rays
# the kernels cannot read in place, converted by cast/rays.py), up to this
# size each: a fresh array faults its pages in as it is written, which
# cost more than the conversion (docs/benchmarks.md, "Ray queries").
_SCRATCH_MAX_BYTES = 8 << 20
_scratch = threading.local()


def scratch_rows(n, slot):
    """n uninitialised (n, 3) float64 rows, this thread's buffer ``slot``
    (0 origins, 1 directions) when they fit: valid until its next call."""
    if n * 24 > _SCRATCH_MAX_BYTES:
        return np.empty((n, 3))
    buffers = getattr(_scratch, "rows", None)
    if buffers is None:
        buffers = _scratch.rows = {}
    buf = buffers.get(slot)
    if buf is None or len(buf) < n:
        buf = buffers[slot] = np.empty((n, 3))
    return buf[:n]


def ray_scene(geo, acc):
    """The ray queries' blocks' ``scene``: geometry and layout packed
    (packed.py), made once for the calls on them."""
    return Packed((geo, acc))


def cast_closest(scene, origins, dirs, t_min, t_max, out_t, out_prim, out_u, out_v,
                 cnt_rows, clock, entries=None):
    """Closest hit of ray i = (origins[i], dirs[i]) with t_min[i] < t < t_max[i]
    (rays as kernel_rays takes them) in ``scene`` (ray_scene's); through
    the compiled entries kept in ``entries`` if given (a prepared scene's:
    run_blocks)."""
    outs = (out_t, out_prim, out_u, out_v)
    run_blocks(closest_block(scene.record[1], origins.shape[0]),
               (scene, *kernel_rays(origins, dirs, t_min, t_max), outs), cnt_rows, clock,
               entries)


def cast_occluded(scene, origins, dirs, t_min, t_max, out_hit, cnt_rows, clock, entries=None):
    """Whether anything is hit with t_min[i] < t < t_max[i] (stops at the
    first); ``entries`` as cast_closest's."""
    run_blocks(occluded_block(scene.record[1], origins.shape[0]),
               (scene, *kernel_rays(origins, dirs, t_min, t_max), out_hit), cnt_rows, clock,
               entries)


# The renderer's calls (kernels/waves.py, path_waves.py): one thread's
# rays through the same compiled kernels as cast_closest and cast_occluded,
# in the calling thread, through the thread's ``entries`` (entry_of).  On
# a structure with packets, the packet kernels: with a ``tally``
# (ray_tally's row) every ray counts into it, and its counts then go to
# row rows[0] of cnt: a call's rays lie in one strip of one band, so each
# band's sums, the statistics, stay each ray's own counts (in the
# packet's order of visits).  Without one (the cost AOV's per-ray rows)
# ray i counts into row rows[i] of cnt, and the same kernel takes every
# ray alone.  So a render compiles one closest-hit and one any-hit kernel
# whatever its options.  Packets bought 1.3-1.6x on soft shadows, and
# 1.2x on a whole render for camera rays (docs/benchmarks.md, "A new
# machine: AVX-512", "Camera rays through packets").
def ray_tally(acc, per_ray):
    """A thread's counter row for the renderer's packet calls (the rays'
    ``tally``), or None where rays go one at a time: per-ray counter rows
    (``per_ray``: the cost AOV's) or a structure without packets."""
    return None if per_ray or not has_packets(acc) else np.zeros((1, COLUMNS), np.int64)


def _render_call(packet_block, single_block, args, cnt, rows, entries, tally):
    """A renderer's call of args' rays (the scene first) through the packet
    kernel (a structure with packets) or the one-ray kernel, counting as
    ray_tally's comment says."""
    call = entry_of(packet_block if has_packets(args[0].record[1]) else single_block, entries)
    if tally is None:
        call(*args, cnt, rows, np.zeros(1, np.int64))
        return
    call(*args, tally, _ONE_ROW, np.zeros(1, np.int64))
    _settle(tally, cnt, rows)


def closest_rays(scene, rays, outs, cnt, rows, entries, tally=None):
    """Closest hits of rays = (origins, dirs, t_min, t_max) into outs =
    (t, prim, u, v), in the calling thread; scene: ray_scene's."""
    _render_call(_closest_block, _closest_single, (scene, rays, FLOAT64_RAYS, outs), cnt,
                 rows, entries, tally)


def occluded_rays(scene, rays, out_hit, cnt, rows, entries, tally=None):
    """cast_occluded of rays = (origins, dirs, t_min, t_max), as closest_rays."""
    _render_call(_occluded_block, _occluded_single, (scene, rays, FLOAT64_RAYS, out_hit),
                 cnt, rows, entries, tally)


def _settle(tally, cnt, rows):
    """tally's counts into row rows[0] of cnt, and tally back to 0."""
    if len(rows):
        cnt[rows[0]] += tally[0, :cnt.shape[1]]
    tally[0] = 0


# Shell sort's gaps (Ciura 2001, "Best Increments for the Average Case of
# Shellsort"): a ray's hits are sorted in place, since the kernels cannot
# allocate; most rays have a few, where it is an insertion sort.
_GAPS = (701, 301, 132, 57, 23, 10, 4, 1)


@njit(**JIT)
def sort_hits(t, prim, u, v, lo, hi):
    """Rows lo:hi of the hit arrays in order of (t, primitive id), the
    canonical order of hits (ray.closer)."""
    for gap in _GAPS:
        for i in range(lo + gap, hi):
            ti, pi, ui, vi = t[i], prim[i], u[i], v[i]
            j = i
            while j - gap >= lo and (t[j - gap] > ti or (t[j - gap] == ti and prim[j - gap] > pi)):
                t[j], prim[j], u[j], v[j] = t[j - gap], prim[j - gap], u[j - gap], v[j - gap]
                j -= gap
            t[j], prim[j], u[j], v[j] = ti, pi, ui, vi


# list_intersections' rows are taken by each thread in slabs of at least
# SLAB rows (lowlevel.take_rows), and a ray's hits go in the next rows of
# its thread's slab; so rows are used as the hits come, whatever each ray
# has, and a ray is traversed again only where its hits overrun the slab.
SLAB = 4096


@njit(**BLOCK)
def _listing_block(scene, rays, narrow, start, fixed, slab, outs, found, cnt, clock):
    geo, acc = unpack(scene)
    _, _, t_min, t_max = rays
    out_t, out_prim, out_u, out_v = outs
    n = t_min.shape[0]
    rows = out_t.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    cursor = frame_array(2, np.int64)
    saved = frame_array(N_COUNTERS, np.int64)
    wide = frame_array(WIDE, np.float64), frame_array(WIDE, np.float64)
    pos = 0
    slab_end = 0    # no slab yet: the first ray with a hit takes one
    c = take_ticket(clock)
    while c < n_chunks:
        origins, dirs = widen_rays(narrow, rays[0], rays[1], c * CHUNK,
                                   min(n, (c + 1) * CHUNK), wide)
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            found[i] = 0
            if not fixed:
                start[i] = pos
            if not ray_ok(origins, dirs, t_min, t_max, i):
                cnt[BAD_RAYS] += 1
                continue
            if fixed:
                pos, slab_end = start[i], start[i + 1]
            for k in range(N_COUNTERS):
                saved[k] = cnt[k]
            while True:
                cursor[0] = pos
                cursor[1] = slab_end
                ray = make_listing_ray(origins[i, 0], origins[i, 1], origins[i, 2],
                                       dirs[i, 0], dirs[i, 1], dirs[i, 2], t_min[i],
                                       out_t, out_prim, out_u, out_v, cursor)
                end = list_hits(geo, acc, ray, t_max[i], cnt)
                found[i] = end - pos
                if fixed or end <= slab_end:
                    sort_hits(out_t, out_prim, out_u, out_v, pos, min(end, slab_end))
                    pos = end
                    break
                # Past the slab's end: a new slab, and the ray again into
                # it (its counters as if traversed once), unless the rows
                # are spent: then start -1, and the caller traverses it again.
                size = max(slab, end - pos)
                s = take_rows(clock, size)
                if s + (end - pos) > rows:
                    start[i] = -1
                    pos = slab_end = rows
                    break
                pos = start[i] = s
                slab_end = min(s + size, rows)
                for k in range(N_COUNTERS):
                    cnt[k] = saved[k]
        c = take_ticket(clock)


def cast_listing(scene, rays, start, fixed, slab, outs, found, cnt_rows, clock, entries=None):
    """Every hit of ray i = (origins[i], dirs[i]) of rays = (origins, dirs,
    t_min, t_max) (as kernel_rays takes them) with t_min[i] < t <
    t_max[i], each crossing of a closed surface once, in order of (t,
    primitive id), into rows of outs (its t, prim, u and v arrays):
    one traversal that never narrows the interval, as cast_counts's.
    found[i] gets the number of hits found, which is that count.

    fixed: the rays' rows are given, ray i's start[i]:start[i + 1] (hits
    past them are counted, not written).  Otherwise each thread takes rows
    in slabs of at least ``slab`` (clock[1], 0 at the call, counts the rows
    taken) and start[i] gets ray i's first row, or -1 where the rows ran
    out before its hits were written.  scene: ray_scene's, of the
    counting layout; ``entries`` as cast_closest's."""
    run_rows(entry_of(_listing_block, entries),
             (scene, *kernel_rays(*rays), start, fixed, slab, outs, found), cnt_rows, clock)


@njit(**BLOCK)
def _counts_block(scene, rays, narrow, out_count, cnt, clock):
    geo, acc = unpack(scene)
    origins, dirs, t_min, t_max = rays
    count_rays(geo, acc, origins, dirs, t_min, t_max, narrow, out_count, cnt, clock, CHUNK)


def cast_counts(scene, origins, dirs, t_min, t_max, out_count, cnt_rows, clock, entries=None):
    """How many times ray i meets the surfaces with t_min[i] < t < t_max[i],
    each crossing of a closed surface once: one traversal that never
    narrows the interval, with the crossing triangle test (CrossingRay), a
    chunk of rays at a time (query.count_rays: the BVH keeps two rays in
    flight); scene: ray_scene's, of the counting layout; ``entries`` as
    cast_closest's."""
    run_rows(entry_of(_counts_block, entries),
             (scene, *kernel_rays(origins, dirs, t_min, t_max), out_count), cnt_rows, clock)
