"""Rays put in a coherent order for a query, and its answers put back: the
kernels of cast/ordering.py, which decides when and runs them, a window
of rays a thread.

A ray's key is a Morton code (bits interleaved) of the coordinates that
vary over the call's rays, quantised within their range: the origin's x,
y, z and the direction's two coordinates on the cube face it points
through, the face in the top bits (Garanzha & Loop 2010, "Fast Ray
Sorting and Breadth-First Packet Traversal for GPU Ray Tracing", key the
origin and direction; Morton codes by table, one row a coordinate with
its bits already spread).  Rays sorted by key lie near their neighbours
in position and direction, so packets of neighbouring rays share their
nodes, and single rays find their neighbours' nodes in cache.

Each kernel works on one window of the call's rays, lo .. lo + m - 1, on
the thread that holds the window; origins and dirs are (n, 3) rows or the
same (n, 6) rows twice (the direction the last 3 columns), float32 or
float64, as the queries' kernels read them.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BLOCK, JIT
from raytrace.kernels.lowlevel import frame_array, prefetch

KEY_BITS = 19          # the Morton code's; the face (0-5) in the 3 bits above them
HALF = 7               # a cell's bits a table row spreads: cells of up to 14 bits
AHEAD = 16             # rays: a gather or scatter asks for ray i + AHEAD's lines at ray i
_DIGIT = 11            # bits a pass of the sort: 2 passes for the 22-bit key
_BUCKETS = 1 << _DIGIT
SAMPLE_MAX = 256       # rays neighbours_apart looks at, at most


@njit(**JIT)
def _cell(x, lo, scale, top):
    """x's cell, 0 .. top, in a range starting at lo of cells 1 / scale
    wide (scale 0: always 0); NaN goes to cell 0.  Selects, not branches:
    a shuffled set's rays go either way at random."""
    q = (x - lo) * scale
    q = q if q > 0.0 else 0.0
    return int(q if q < top else np.float64(top))


@njit(**JIT)
def _spread(tables, c, q, high_shift):
    """Cell q of coordinate c with its bits spread: two rows of 2^HALF
    entries (small enough to stay in the first-level cache), its high
    half's moved up by high_shift."""
    return (tables[c, q >> HALF] << high_shift) | tables[c, q & ((1 << HALF) - 1)]


@njit(**JIT)
def _keys(rays, lo, keys, records, low, scale, tables, top, high_shift):
    """keys[i] of ray lo + i of rays = (origins, dirs, t_min, t_max): the
    face its direction points through (0-5: +x, -x, +y, -y, +z, -z) above
    its five coordinates' cells (at most ``top``) with their bits spread
    (``_spread``), each cell taken from ``low`` and ``scale`` (origin x, y,
    z, then the direction's two coordinates on the face, each divided by
    the major one).  Row i of ``records`` gets the ray as float64: origin,
    direction, t_min and t_max, one 64-byte line (the bounds only where
    records has 8 columns)."""
    origins, dirs, t_min, t_max = rays
    col = dirs.shape[1] - 3
    bounds = records.shape[1] == 8
    for i in range(keys.shape[0]):
        r = lo + i
        for a in range(3):
            records[i, a] = origins[r, a]
            records[i, 3 + a] = dirs[r, col + a]
        if bounds:
            records[i, 6] = t_min[r]
            records[i, 7] = t_max[r]
        key = np.uint32(0)
        for k in range(3):
            key |= _coordinate_bits(tables, k, np.float64(origins[r, k]), low, scale, top,
                                    high_shift)
        face, a, b = _on_face(np.float64(dirs[r, col]), np.float64(dirs[r, col + 1]),
                              np.float64(dirs[r, col + 2]))
        key |= _coordinate_bits(tables, 3, a, low, scale, top, high_shift)
        key |= _coordinate_bits(tables, 4, b, low, scale, top, high_shift)
        keys[i] = key | (np.uint32(face) << np.uint32(KEY_BITS))


@njit(**JIT)
def _coordinate_bits(tables, c, x, low, scale, top, high_shift):
    """Coordinate c's cell of value x with its bits spread (``_spread``),
    taken from low[c] and scale[c]; no bits where c does not vary over the
    call (scale 0)."""
    if scale[c] == 0.0:
        return np.uint32(0)
    return _spread(tables, c, _cell(x, low[c], scale[c], top), high_shift)


@njit(**JIT)
def _on_face(dx, dy, dz):
    """(the face of the cube a direction points through, 0-5: +x, -x, +y,
    -y, +z, -z; its two other coordinates over the major one's size).
    The major axis by selects (the first of equal ones), and a product by
    the inverse, not two divisions: a key only has to be the same for the
    same ray."""
    ax, ay, az = abs(dx), abs(dy), abs(dz)
    on_x = (ax >= ay) & (ax >= az)
    on_y = (not on_x) & (ay >= az)
    inv = 1.0 / (ax if on_x else (ay if on_y else az))
    a = dy if on_x else dx
    b = dy if not (on_x | on_y) else dz
    negative = dx < 0.0 if on_x else (dy < 0.0 if on_y else dz < 0.0)
    return (0 if on_x else (2 if on_y else 4)) + negative, a * inv, b * inv


@njit(**BLOCK)
def sample_coords(origins, dirs, rows, coords, face):
    """The key's five coordinates of rays ``rows`` (cast/ordering.py's
    sample): coords[k] = origin x, y, z and _on_face's two, face[k] its
    face."""
    col = dirs.shape[1] - 3
    for k in range(rows.shape[0]):
        r = rows[k]
        for a in range(3):
            coords[k, a] = origins[r, a]
        face[k], coords[k, 3], coords[k, 4] = _on_face(
            np.float64(dirs[r, col]), np.float64(dirs[r, col + 1]), np.float64(dirs[r, col + 2]))


@njit(**BLOCK)
def sample_keys(coords, face, key, keys):
    """_keys' keys of the sample's coordinates (sample_coords), ``key`` =
    (low, scale, tables, top, high_shift)."""
    low, scale, tables, top, high_shift = key
    for k in range(keys.shape[0]):
        bits = np.uint32(0)
        for c in range(5):
            bits |= _coordinate_bits(tables, c, coords[k, c], low, scale, top, high_shift)
        keys[k] = bits | (np.uint32(face[k]) << np.uint32(KEY_BITS))


@njit(**JIT)
def _sort(keys, spare, order, spare_order):
    """The window's order by key (stable): a radix sort, least significant
    digit first, 2 passes of 11 bits (both digits counted in one sweep),
    skipping a pass whose digit all keys share.  keys is overwritten; the
    order ends in ``order`` (copied there if the last pass left it in
    spare_order)."""
    n = keys.shape[0]
    low = frame_array(_BUCKETS, np.int64)
    high = frame_array(_BUCKETS, np.int64)
    for j in range(_BUCKETS):
        low[j] = 0
        high[j] = 0
    for i in range(n):
        low[keys[i] & (_BUCKETS - 1)] += 1
        high[(keys[i] >> _DIGIT) & (_BUCKETS - 1)] += 1
    moved = 0
    src, dst, src_order, dst_order = keys, spare, order, spare_order
    for shift in (0, _DIGIT):
        count = low if shift == 0 else high
        if n == 0 or count[(src[0] >> shift) & (_BUCKETS - 1)] == n:
            continue
        total = 0
        for j in range(_BUCKETS):
            c = count[j]
            count[j] = total
            total += c
        for i in range(n):
            digit = (src[i] >> shift) & (_BUCKETS - 1)
            at = count[digit]
            dst[at] = src[i]
            dst_order[at] = i if moved == 0 else src_order[i]
            count[digit] = at + 1
        src, dst, src_order, dst_order = dst, src, dst_order, src_order
        moved += 1
    if moved == 0:
        for i in range(n):
            order[i] = i
    elif moved == 1:
        for i in range(n):
            order[i] = spare_order[i]


@njit(**BLOCK)
def order_window(rays, lo, key, sorting, out):
    """Rays lo .. lo + m - 1 of ``rays`` = (origins, dirs, t_min, t_max) in
    key order, ``key`` = (low, scale, tables, top, high_shift) as _keys
    takes them, ``sorting`` = (keys, spare, order, spare_order, records,
    the same records as 1-D) of m rows each (m: the window's rays; records
    (m, 8), or (m, 6) where the bounds need no order): order[i] is the
    window's ray at row i of out = (origins, dirs: float64 (m, 3); t_min,
    t_max: (m,), or empty where the bounds are one number for every ray).
    The rays are first copied in their order, a record of one cache line a
    ray (_keys), so the reads in key order that follow wait on one line a
    ray, not on two or four from the call's arrays; each read asks for
    the line of the read AHEAD rays on."""
    low, scale, tables, top, high_shift = key
    keys, spare, order, spare_order, records, flat = sorting
    to_origins, to_dirs, to_t_min, to_t_max = out
    _keys(rays, lo, keys, records, low, scale, tables, top, high_shift)
    _sort(keys, spare, order, spare_order)
    m = keys.shape[0]
    width = records.shape[1]
    bounds = to_t_min.shape[0] > 0
    for i in range(m):
        if i + AHEAD < m:
            prefetch(flat, order[i + AHEAD] * width)
        j = order[i]
        for a in range(3):
            to_origins[i, a] = records[j, a]
            to_dirs[i, a] = records[j, 3 + a]
        if bounds:
            to_t_min[i] = records[j, 6]
            to_t_max[i] = records[j, 7]


@njit(**BLOCK)
def put_back_closest(order, lo, t, prim, u, v, to_t, to_prim, to_u, to_v):
    """Answer i of the ordered window back to ray lo + order[i]."""
    m = order.shape[0]
    for i in range(m):
        if i + AHEAD < m:
            ahead = lo + order[i + AHEAD]
            prefetch(to_t, ahead)
            prefetch(to_prim, ahead)
            prefetch(to_u, ahead)
            prefetch(to_v, ahead)
        j = lo + order[i]
        to_t[j] = t[i]
        to_prim[j] = prim[i]
        to_u[j] = u[i]
        to_v[j] = v[i]


@njit(**BLOCK)
def put_back_column(order, lo, values, to_values):
    """put_back_closest's for one array: any hit's flags, counts."""
    m = order.shape[0]
    for i in range(m):
        if i + AHEAD < m:
            prefetch(to_values, lo + order[i + AHEAD])
        to_values[lo + order[i]] = values[i]


@njit(**JIT)
def _middle(values, m):
    """The median (upper middle) of values[:m], sorting them in place (m
    is small: insertion sort)."""
    for i in range(1, m):
        x = values[i]
        j = i
        while j > 0 and values[j - 1] > x:
            values[j] = values[j - 1]
            j -= 1
        values[j] = x
    return values[m // 2]


@njit(**BLOCK)
def neighbours_apart(origins, dirs, n, runs, run):
    """cast/ordering.py's first look at a call's rays: ``runs`` runs of
    ``run`` consecutive rays spread over the call (runs * run at most
    SAMPLE_MAX, the frame's arrays).  Returns (whether
    neighbours in the given order lie far apart: the median step between
    neighbours' origins, or unit directions, the largest coordinate's,
    exceeds 1/64 of the sample's extent; how many of the origin's 3
    coordinates vary over the sample, and of the unit direction's, at
    most 2).  Compiled: the same in NumPy took 20 operations, 50 us back
    to back and 180 us after a query had filled the caches."""
    col = dirs.shape[1] - 3
    lo = frame_array(6, np.float64)
    hi = frame_array(6, np.float64)
    cur = frame_array(6, np.float64)
    prev = frame_array(6, np.float64)
    for a in range(6):
        lo[a] = np.inf
        hi[a] = -np.inf
    steps_o = frame_array(SAMPLE_MAX, np.float64)
    steps_d = frame_array(SAMPLE_MAX, np.float64)
    k = 0
    for r in range(runs):
        start = (n - run) * r // max(runs - 1, 1)
        for j in range(run):
            i = start + j
            for a in range(3):
                cur[a] = origins[i, a]
                cur[3 + a] = dirs[i, col + a]
            norm = np.sqrt(cur[3] * cur[3] + cur[4] * cur[4] + cur[5] * cur[5])
            for a in range(3, 6):
                cur[a] = cur[a] / norm
            for a in range(6):
                lo[a] = min(lo[a], cur[a])
                hi[a] = max(hi[a], cur[a])
            if j > 0:
                so = 0.0
                sd = 0.0
                for a in range(3):
                    so = max(so, abs(cur[a] - prev[a]))
                    sd = max(sd, abs(cur[3 + a] - prev[3 + a]))
                steps_o[k] = so
                steps_d[k] = sd
                k += 1
            for a in range(6):
                prev[a] = cur[a]
    extent_o = max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
    extent_d = max(hi[3] - lo[3], hi[4] - lo[4], hi[5] - lo[5])
    far = (_middle(steps_o, k) > extent_o / 64) | (_middle(steps_d, k) > extent_d / 64)
    varying_o = (hi[0] > lo[0]) + (hi[1] > lo[1]) + (hi[2] > lo[2])
    varying_d = min((hi[3] > lo[3]) + (hi[4] > lo[4]) + (hi[5] > lo[5]), 2)
    return far, varying_o + varying_d
