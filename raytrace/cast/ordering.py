"""A query's rays traced in a coherent order when they come in an
incoherent one (issue 40: "so that the caller need not order rays").

Camera rays in image order go as packets (accel/bvh/packet.py) and find
their neighbours' nodes in cache; the same rays shuffled, or rays from one
point towards random points of a mesh, go one by one, each from memory.
So a large call first looks at a sample of its rays (``_worth_a_look``,
then ``plan``): where the rays, sorted by a Morton key of origin and
direction (kernels/ray_order.py), would lie much nearer their neighbours
than they do in the order given, each thread takes windows of the call's
rays, sorts a window, traces it in that order through the query's own
kernel and puts its answers back.  Each ray's answer is its own whatever
the order (bit for bit: a packet's ray gets what it gets alone), so only
the time and the counters' visits change.

The decision, from SAMPLE rays in RUNS runs of consecutive rays spread
over the call: ``given``, the median number of leading key bits that
neighbours in the given order share; ``sorted``, the median that
neighbours in the sample's sorted order share, plus the bits the full
call's density adds (log2 of calls' rays over the sample's).  Sort when
``sorted`` exceeds ``given`` by GAIN_MIN levels and reaches SORTED_MIN.
"""
import functools
import itertools
import threading

import numpy as np

ORDER_MIN = 65536      # rays: below it a call is traced as given
CHECK_RUNS, CHECK_RUN = 16, 8     # _worth_a_look's sample
RUNS, RUN = 32, 32     # plan's sample: RUNS runs of RUN consecutive rays, and as many spread
KEY_BITS = 19          # kernels/ray_order.py's
HALF = 7               # kernels/ray_order.py's
SORTED_MIN = 6         # levels: sorted neighbours share a cell 1/64 of each range
GAIN_MIN = 3           # levels more than the given order's neighbours share
WINDOW_MAX = 1 << 18   # rays a window: a thread's share of the call, cut to this
PRIMS_MIN = 256        # a structure of fewer primitives is traced as given


@functools.lru_cache(maxsize=32)
def _tables(varying):
    """The keys' rows of spread bits (ray_order._spread), one for each of
    the 5 coordinates: entry q of coordinate c's row has q's HALF bits at
    every len(varying)-th position; zero rows for coordinates that do not
    vary.  Cached: the kernels only read them."""
    tables = np.zeros((5, 1 << HALF), np.uint32)
    q = np.arange(1 << HALF, dtype=np.uint32)
    dims = len(varying)
    for slot, c in enumerate(varying):
        for j in range(HALF):
            tables[c] |= ((q >> j) & 1) << (j * dims + dims - 1 - slot)
    return tables


def _shared_bits(a, b):
    """Leading bits that keys a and b (of KEY_BITS + 3 bits) share."""
    x = (a ^ b).astype(np.uint64)
    with np.errstate(divide="ignore"):
        length = np.where(x > 0, np.floor(np.log2(np.maximum(x, 1))) + 1, 0)
    return KEY_BITS + 3 - length


@functools.lru_cache(maxsize=8)
def _plan_rows(n):
    """plan's sample of a call of n rays: RUNS runs of RUN consecutive
    rays, then RUNS * RUN spread evenly."""
    starts = np.linspace(0, n - RUN, RUNS).astype(np.int64)
    runs = (starts[:, None] + np.arange(RUN)).ravel()
    spread = np.linspace(0, n - 1, RUNS * RUN).astype(np.int64)
    return np.concatenate([runs, spread])


def plan(origins, dirs, n):
    """The sample's verdict and the key's constants: (given, sorted)
    shared levels, and (lo, scale, tables, top, high_shift) as
    ray_order's keys take them, for rays origins, dirs ((n, 3) rows, or
    (n, 6) rows twice)."""
    from raytrace.kernels import ray_order
    rows = _plan_rows(n)
    coords, face = np.empty((len(rows), 5)), np.empty(len(rows), np.int64)
    ray_order.sample_coords(origins, dirs, rows, coords, face)
    with np.errstate(invalid="ignore"):
        lo = np.fmin.reduce(coords, axis=0)
        hi = np.fmax.reduce(coords, axis=0)
    varying = [c for c in range(5) if hi[c] > lo[c]]
    dims = max(len(varying), 1)
    bits = min(KEY_BITS // dims, 2 * HALF)
    span = np.where(hi > lo, hi - lo, 1.0)
    scale = np.where(hi > lo, (1 << bits) / span, 0.0)
    lo = np.where(np.isfinite(lo), lo, 0.0)
    tables = _tables(tuple(varying))
    # A cell of more than HALF bits takes a second row, its bits above the
    # first row's; with fewer the second row reads entry 0 (no bits), and
    # a shift past 31 is left out.
    top, high_shift = (1 << bits) - 1, HALF * dims if bits > HALF else 0
    key = np.empty(len(rows), np.uint32)
    ray_order.sample_keys(coords, face, (lo, scale, tables, top, high_shift), key)
    by_run = key[:RUNS * RUN].reshape(RUNS, RUN)
    skip = 3 + KEY_BITS - bits * dims     # the face's bits and the unused ones
    given = (float(np.median(_shared_bits(by_run[:, 1:], by_run[:, :-1]))) - skip) / dims
    ordered = np.sort(key[RUNS * RUN:])
    sorted_ = ((float(np.median(_shared_bits(ordered[1:], ordered[:-1]))) - skip) / dims
               + np.log2(n / len(ordered)) / dims)
    return given, sorted_, (lo, scale, tables, top, high_shift)


def _worth_a_look(origins, dirs, n):
    """Whether ordering might pay, from CHECK_RUNS runs of CHECK_RUN
    consecutive rays (kernels/ray_order.py neighbours_apart, a few us):
    neighbours in the given order lie far apart (camera and shadow rays in
    image order stop here), and n rays are enough to fill SORTED_MIN
    levels of cells over the coordinates that vary (rays from points
    spread in space in all directions, 5 coordinates, would need 2^30:
    they stop here)."""
    from raytrace.kernels import ray_order
    far, dims = ray_order.neighbours_apart(origins, dirs, n, CHECK_RUNS, CHECK_RUN)
    return bool(far) and np.log2(n) >= SORTED_MIN * max(dims, 1)


def windows(n, threads):
    """[lo, hi) of the call's windows: one a thread, more of at most
    WINDOW_MAX rays for a large call, near-equal."""
    count = max(threads, -(-n // WINDOW_MAX))
    cuts = [n * k // count for k in range(count + 1)]
    return list(zip(cuts[:-1], cuts[1:]))


# Each calling thread keeps its last call's buffer for its next call (a
# fresh one faults its pages in as it is written: kernels/cast.py
# scratch_rows), up to this size.
_KEPT_MAX_BYTES = 64 << 20
_kept = threading.local()


def _buffer(nbytes):
    """An uninitialised uint8 array of nbytes starting on a 64-byte line,
    this thread's kept one when it fits."""
    if nbytes > _KEPT_MAX_BYTES:
        return _on_a_line(np.empty(nbytes + 64, np.uint8), nbytes)
    buf = getattr(_kept, "buffer", None)
    if buf is None or len(buf) < nbytes + 64:
        buf = _kept.buffer = np.empty(max(nbytes, 1 << 20) + 64, np.uint8)
    return _on_a_line(buf, nbytes)


def _on_a_line(buf, nbytes):
    """nbytes of buf from its first 64-byte boundary (a record of 8
    float64s is then one cache line)."""
    skip = -buf.__array_interface__["data"][0] % 64
    return buf[skip:skip + nbytes]


def _carve(buf, lo, specs):
    """Arrays of the (count, dtype) or ((rows, 3), dtype) specs laid one
    after another in buf from byte lo, each 64-byte aligned; returns them
    and the byte after the last."""
    out = []
    for shape, dtype in specs:
        size = int(np.prod(shape)) * np.dtype(dtype).itemsize
        out.append(buf[lo:lo + size].view(dtype).reshape(shape))
        lo += -(-size // 64) * 64
    return out, lo


def decide(origins, dirs, n, prims):
    """plan's key constants where the call's rays are worth ordering, else
    None.  prims: the structure's primitives."""
    if n < ORDER_MIN or prims < PRIMS_MIN or not _worth_a_look(origins, dirs, n):
        return None
    given, sorted_, key = plan(origins, dirs, n)
    if sorted_ < SORTED_MIN or sorted_ - given < GAIN_MIN:
        return None
    return key


def trace_in_order(key, trace, rays, uniform, answers, threads):
    """Trace rays (origins, dirs, t_min, t_max, as rays._rays makes them)
    window by window in key order on ``threads`` threads: each window's
    rays sorted and gathered (ray_order.order_window), traced by
    ``trace(window rays, window answers, counter row)``, and its answers
    put back into ``answers`` (the call's: (t, prim, u, v) of closest hits,
    or one array: any hit's flags, counts).
    ``uniform``: t_min and t_max are one number for every ray, so they are
    not gathered.  Returns the counter rows, one a window."""
    from raytrace.kernels import cast, ray_order
    from raytrace.kernels.threads import run_on_threads
    origins, dirs, t_min, t_max = rays
    n = len(t_min)
    spans = windows(n, threads)
    cnt = np.zeros((len(spans), cast.COLUMNS), np.int64)
    closest = len(answers) == 4
    width = 6 if uniform else 8         # a record: origin, direction, and the bounds
    per_ray = [((1,), np.uint32), ((1,), np.uint32), ((1,), np.int64), ((1,), np.int64),
               ((1, width), np.float64), ((1, 3), np.float64), ((1, 3), np.float64)]
    per_ray += [((1,), np.float64)] * (0 if uniform else 2)
    per_ray += [((1,), a.dtype) for a in answers]
    widest = max(hi - lo for lo, hi in spans)
    slot = sum(-(-widest * int(np.prod(s)) * np.dtype(t).itemsize // 64) * 64 for s, t in per_ray)
    buf = _buffer(slot * threads)
    tickets = itertools.count()
    none = np.empty(0)

    def work(t):
        for w in iter(lambda: next(tickets), None):
            if w >= len(spans):
                return
            lo, hi = spans[w]
            m = hi - lo
            specs = [((m,) + s[1:], d) for s, d in per_ray]
            (keys, spare, order, spare_order, records, to_o, to_d, *rest), _ = _carve(
                buf, t * slot, specs)
            bounds = (t_min[:m], t_max[:m]) if uniform else tuple(rest[:2])
            out = rest[0 if uniform else 2:]
            ray_order.order_window((origins, dirs, t_min, t_max), lo, key,
                                   (keys, spare, order, spare_order, records, records.reshape(-1)),
                                   (to_o, to_d, *((none, none) if uniform else bounds)))
            trace((to_o, to_d, *bounds), out, cnt[w:w + 1])
            if closest:
                ray_order.put_back_closest(order, lo, *out, *answers)
            else:
                ray_order.put_back_column(order, lo, out[0], answers[0])
    run_on_threads([functools.partial(work, t) for t in range(threads)])
    return cnt


def warm(dtypes=(np.float64, np.float32)):
    """Compile the ordering's kernels (``raytrace warmup``'s queries step,
    and a first large query's second process: cast/precompile.py) for rays
    of ``dtypes``, the types trace_in_order passes."""
    from raytrace.kernels import ray_order
    m = 2
    for dtype in dtypes:
        ray_order.neighbours_apart(np.zeros((m, 3), dtype), np.ones((m, 3), dtype), m, 1, m)
    key = (np.zeros(5), np.zeros(5), _tables((0,)), 1, 0)
    order = np.zeros(m, np.int64)
    coords, face = np.zeros((m, 5)), np.zeros(m, np.int64)
    for dtype in dtypes:
        ray_order.sample_coords(np.zeros((m, 3), dtype), np.ones((m, 3), dtype), order, coords,
                                face)
    ray_order.sample_keys(coords, face, key, np.zeros(m, np.uint32))
    for dtype in dtypes:
        rows = np.zeros((m, 3), dtype)
        bounds = np.zeros(m), np.zeros(m)
        records = np.zeros((m, 8))
        ray_order.order_window((rows, rows, *bounds), 0, key,
                               (np.zeros(m, np.uint32), np.zeros(m, np.uint32), order,
                                np.zeros(m, np.int64), records, records.reshape(-1)),
                               (np.zeros((m, 3)), np.zeros((m, 3)), *bounds))
    t, prim = np.zeros(m), np.zeros(m, np.int64)
    ray_order.put_back_closest(order, 0, t, prim, t, t, t.copy(), prim.copy(), t.copy(), t.copy())
    for dtype in (np.bool_, np.int64):      # any hit's flags, counts
        column = np.zeros(m, dtype)
        ray_order.put_back_column(order, 0, column, column.copy())
