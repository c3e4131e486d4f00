"""The two questions every structure answers (pbrt's Intersect and
IntersectP): the closest hit of a ray, and whether anything blocks it.

A structure is a type: its layout, a namedtuple class of its own
(``raytrace/accel/<name>/``).  Each structure's traversal module registers its
traversal for that class, and a kernel calling ``closest_hit(geo, acc,
...)`` is compiled once per layout type with that structure's traversal
chosen at compile time (Numba's ``@overload``): a BVH render never
compiles, or branches over, the grid's code.
"""
import numpy as np
from numba import njit
from numba.core.errors import TypingError
from numba.extending import overload

from raytrace.kernels.counters import BAD_RAYS, PRIM_HITS
from raytrace.kernels.jit import OVERLOAD, STAGE
from raytrace.kernels.lowlevel import frame_array, take_ticket
from raytrace.kernels.prims import (
    count_unbounded_hits,
    planes_closest,
    planes_occluded,
    record_unbounded_hits,
)
from raytrace.kernels.ray import WIDE, make_crossing_ray, ray_ok, widen_rays

# What a traversal is made for, a compile-time constant of each structure's
# one traversal loop: the closest hit; any hit (stop at the first); every
# hit (never stop, never narrow the interval: each hit is counted in
# cnt[PRIM_HITS] and none kept).
CLOSEST, ANY_HIT, ALL_HITS = 0, 1, 2
# What a packet query returns (closest_packet, occluded_packet, the BVH's
# count_packet): its rays did not go as a packet, and go one by one; they
# went; they went, but shared too few nodes to gain by it, so the rest of
# the caller's chunk goes one by one (accel/bvh/packet.py, SHARED_MIN).
NOT_PACKED, PACKED, SPARSE = 0, 1, 2
MODES = ("closest-hit", "any-hit", "every-hit")

# layout class -> (closest, any_hit, all_hits): compiled functions (geo,
# acc, ray, t_max, cnt) -> Hit made from one loop each (MODES order).
_TRAVERSALS = {}


def register(layout, closest, any_hit, all_hits):
    """Make ``layout`` (a structure's namedtuple class) queryable.  None:
    the layout does not answer that question; a structure may count on a
    layout of its own (the BVH: accel.bvh.for_counting, by way of
    accel.registry's Structure.counting_layout)."""
    _TRAVERSALS[layout] = (closest, any_hit, all_hits)


# layout class -> (closest, occluded): Python functions tracing a packet
# of neighbouring rays together (accel/bvh/packet.py), for the
# structures that have them; closest_packet and occluded_packet compile
# them as their implementations.
_PACKETS = {}


def register_packets(layout, closest, occluded):
    """Give ``layout`` packet traversals: (geo, acc, origins, dirs, t_min,
    t_max, i0, m, outputs..., cnt) -> whether rays i0 .. i0 + m - 1 went
    as a packet (if not, nothing is written)."""
    _PACKETS[layout] = (closest, occluded)


def has_packets(layout):
    """Whether a built layout (an instance of its structure's class) has
    packet traversals: a call on any other compiles the one-ray kernel
    only, since its packet kernel would trace every ray alone anyway."""
    return type(layout) in _PACKETS


def _traversal(acc, mode):
    """The traversal registered for acc's layout in ``mode`` (MODES order)."""
    # A layout's class is defined in its structure's package, whose import
    # registers the traversals (raytrace/accel/<name>/__init__.py): a layout
    # unpickled in another process (a Dask worker's scene) brings them along.
    cls = getattr(acc, "instance_class", None)
    if cls not in _TRAVERSALS:
        raise TypingError(f"no traversal registered for structure layout {acc}")
    traversal = _TRAVERSALS[cls][mode]
    if traversal is None:
        raise TypingError(f"structure layout {cls.__name__} has no {MODES[mode]} traversal"
                          + (" (count on structures.counting_layout)" if mode == ALL_HITS else ""))
    return traversal


def structure_closest(geo, acc, ray, t_max, cnt):
    """The structure's own closest hit with 0 < t < t_max (planes, which
    no structure holds, left out): a Hit.  Compiled code only."""
    raise NotImplementedError("compiled code only")


def structure_any(geo, acc, ray, t_max, cnt):
    """A hit of the structure's with 0 < t < t_max, the first found
    (planes left out): a Hit.  Compiled code only."""
    raise NotImplementedError("compiled code only")


# The overloads compile the structure's traversal itself as their
# implementation, not a wrapper calling it: every level of calls compiles
# (optimises and emits) all the code below it again, and a wrapper level
# cost a first render a few tenths of a second a query (docs/benchmarks.md,
# "Camera rays through packets").  closest_hit and occluded add the planes,
# inlined by Numba into their callers, so they are no level either.
@overload(structure_closest, jit_options=OVERLOAD)
def _structure_closest(geo, acc, ray, t_max, cnt):
    return _traversal(acc, CLOSEST).py_func


@overload(structure_any, jit_options=OVERLOAD)
def _structure_any(geo, acc, ray, t_max, cnt):
    return _traversal(acc, ANY_HIT).py_func


@njit(**STAGE)
def closest_hit(geo, acc, ray, t_max, cnt):
    """Closest hit with 0 < t < t_max, planes included: a Hit (prim -1 on a
    miss).  cnt: the caller's counter row, never shared between threads."""
    return planes_closest(geo, ray, t_max, structure_closest(geo, acc, ray, t_max, cnt), cnt)


@njit(**STAGE)
def occluded(geo, acc, ray, t_max, cnt):
    """Whether anything is hit with 0 < t < t_max; stops at the first.
    Planes first: one test each, and the ground blocks many shadow rays."""
    if planes_occluded(geo, ray, t_max, cnt):
        return True
    return structure_any(geo, acc, ray, t_max, cnt).prim >= 0


def count_hits(geo, acc, ray, t_max, cnt):
    """How many primitives the ray hits with its t_min < t < t_max, planes
    included: with a CrossingRay, each crossing of a closed surface once.
    Compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(count_hits, jit_options=OVERLOAD)
def _count_hits(geo, acc, ray, t_max, cnt):
    all_hits = _traversal(acc, ALL_HITS)

    def impl(geo, acc, ray, t_max, cnt):
        before = cnt[PRIM_HITS]
        all_hits(geo, acc, ray, t_max, cnt)
        return cnt[PRIM_HITS] - before + count_unbounded_hits(geo, ray, t_max, cnt)
    return impl


def count_rays(geo, acc, origins, dirs, t_min, t_max, narrow, out, cnt, clock, chunk):
    """out[i] = count_hits of ray i as a CrossingRay, for the rays in the
    chunks of ``chunk`` rays this thread takes by ticket from clock
    (kernels/cast.py; ``narrow``: float32 rays each chunk, of at most
    ray.CHUNK, is widened from first, ray.widen_rays; origins and dirs
    are then empty, and t_min gives the number of rays); a bad ray
    (ray_ok) gets 0 and is counted in cnt[BAD_RAYS].  Through the layout's
    count stream if it has one (register_count_stream), else one ray at a
    time.  Compiled code only."""
    raise NotImplementedError("compiled code only")


# layout class -> count stream: a Python function with count_rays's
# arguments that traces several rays at once (accel/bvh/traverse.py), compiled as
# count_rays itself, not called from a wrapper: every level of calls
# compiles the code below it again, and a stream is large.
_COUNT_STREAMS = {}


def register_count_stream(layout, stream):
    """Give ``layout`` a count stream (count_rays)."""
    _COUNT_STREAMS[layout] = stream


# Not inlined: a stream is large, and its thread's block calls it once.
@overload(count_rays, jit_options=dict(OVERLOAD, forceinline=False))
def _count_rays(geo, acc, origins, dirs, t_min, t_max, narrow, out, cnt, clock, chunk):
    _traversal(acc, ALL_HITS)
    stream = _COUNT_STREAMS.get(acc.instance_class)
    if stream is not None:
        return stream

    def impl(geo, acc, origins, dirs, t_min, t_max, narrow, out, cnt, clock, chunk):
        n = t_min.shape[0]
        wide = frame_array(WIDE, np.float64), frame_array(WIDE, np.float64)
        c = take_ticket(clock)
        while c * chunk < n:
            o_rows, d_rows = widen_rays(narrow, origins, dirs, c * chunk,
                                        min(n, (c + 1) * chunk), wide)
            for i in range(c * chunk, min(n, (c + 1) * chunk)):
                if not ray_ok(o_rows, d_rows, t_min, t_max, i):
                    cnt[BAD_RAYS] += 1
                    out[i] = 0
                    continue
                ray = make_crossing_ray(o_rows[i, 0], o_rows[i, 1], o_rows[i, 2],
                                        d_rows[i, 0], d_rows[i, 1], d_rows[i, 2], t_min[i])
                out[i] = count_hits(geo, acc, ray, t_max[i], cnt)
            c = take_ticket(clock)
    return impl


def list_hits(geo, acc, ray, t_max, cnt):
    """Write down every hit of a ListingRay with its t_min < t < t_max, in
    the order found: the hits count_hits counts (the same traversal, the
    same tests).  Returns the ray's cursor after the last.  Compiled code
    only."""
    raise NotImplementedError("compiled code only")


@overload(list_hits, jit_options=OVERLOAD)
def _list_hits(geo, acc, ray, t_max, cnt):
    all_hits = _traversal(acc, ALL_HITS)

    def impl(geo, acc, ray, t_max, cnt):
        all_hits(geo, acc, ray, t_max, cnt)
        record_unbounded_hits(geo, ray, t_max)
        return ray.cursor[0]
    return impl


def closest_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
    """Closest hits of rays i0 .. i0 + m - 1 (into outs: the t, prim, u and
    v arrays) as one packet, if the
    structure traces packets and the rays can go as one; returns
    NOT_PACKED (nothing is written), PACKED or SPARSE.  Compiled code only."""
    raise NotImplementedError("compiled code only")


def occluded_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
    """occluded() for rays i0 .. i0 + m - 1 (into outs: the blocked flags'
    array) as one packet, as closest_packet.  Compiled code only."""
    raise NotImplementedError("compiled code only")


def _packets(acc, origins, dirs):
    """The layout's packet traversals (registered with its traversal, by its
    structure's package), or None.  A packet reads its rays' rows as one
    block: rays in arrays that are not C-contiguous (the API always passes C
    arrays) go one by one."""
    _traversal(acc, CLOSEST)
    if getattr(origins, "layout", None) != "C" or getattr(dirs, "layout", None) != "C":
        return None
    return _PACKETS.get(acc.instance_class)


# The packet overloads compile the structure's packet query itself as
# their implementation (accel/bvh/packet.py), as count_rays compiles a
# count stream: Numba compiles an @overload's implementation in full even
# where it is inlined, and a level of its own optimises and emits again
# all the packet code it links in (a quarter second a query).
@overload(closest_packet, jit_options=OVERLOAD)
def _closest_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
    packets = _packets(acc, origins, dirs)
    if packets is None:
        def impl(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
            return NOT_PACKED
        return impl
    return packets[0]


@overload(occluded_packet, jit_options=OVERLOAD)
def _occluded_packet(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
    packets = _packets(acc, origins, dirs)
    if packets is None:
        def impl(geo, acc, origins, dirs, t_min, t_max, i0, m, outs, cnt):
            return NOT_PACKED
        return impl
    return packets[1]
