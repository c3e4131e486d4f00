"""Rays and points from the caller to the kernels: shapes, dtypes and
values checked (a bad one named by argument and row), query points put in
Morton order, and the batch kernels called over counter rows."""

import functools

import numpy as np

from raytrace.cast import ordering
from raytrace.errors import RaytraceError
from raytrace.kernels.counters import BAD_RAYS
from raytrace.kernels.limits import FROM_ORIGIN
from raytrace.scene.formats.mesh import MAX_COORD, bad_coordinate_rows

_FLOAT64, _FLOAT32 = np.dtype(np.float64), np.dtype(np.float32)   # compared faster than types


def _as_rows(name, a):
    """(n, 3) float64 array, or (3,) as one row; values are checked later."""
    try:
        raw = np.asarray(a)
        if raw.dtype.kind == "c":
            raise RaytraceError(f"{name}: complex numbers are not coordinates")
        arr = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:   # ragged rows, text
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if arr.ndim == 1 and arr.shape[0] == 3:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise RaytraceError(f"{name}: expected shape (n, 3), got {arr.shape}")
    return kernel_array(arr)


def _ray_rows(name, a, width=3):
    """(n, width) rows of an array of shape (..., width), real numbers of
    any dtype (kernel_array converts them, once), and that leading shape
    (None for (n, width), or (width,) as one row)."""
    try:
        arr = np.asarray(a)
    except (TypeError, ValueError) as exc:   # ragged rows
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    # dtype.kind, not np.iscomplexobj: 2 us a call, a sizeable share of a
    # call of one ray.
    if arr.dtype.kind == "c":
        raise RaytraceError(f"{name}: complex numbers are not coordinates")
    if arr.dtype.kind in "mM":
        raise RaytraceError(f"{name}: dates and times are not coordinates (dtype {arr.dtype})")
    try:
        if arr.dtype.kind not in "biuf":
            arr = arr.astype(np.float64)
    except (TypeError, ValueError) as exc:   # ragged rows, text
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if arr.ndim < 1 or arr.shape[-1] != width:
        raise RaytraceError(f"{name}: expected shape (n, {width}) or (..., {width}), "
                            f"got {arr.shape}")
    if arr.ndim > 2:
        return arr.reshape(-1, width), arr.shape[:-1]
    return (arr[None, :] if arr.ndim == 1 else arr), None


def _shaped(a, shape):
    """A per-ray answer in the rays' leading shape."""
    return a if shape is None else a.reshape(shape + a.shape[1:])


def _interval_end(name, value, n, shape=None):
    """An (n,) float64 array from a number or an array over the rays: (n,)
    or the rays' leading shape."""
    if type(value) is float or type(value) is int:     # the common case, at once
        return _filled(n, FROM_ORIGIN if name == "t_min" and value < 0 else float(value))
    if np.iscomplexobj(value):
        raise RaytraceError(f"{name}: complex numbers are not distances")
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if a.ndim == 0:
        x = float(a)
        return _filled(n, FROM_ORIGIN if name == "t_min" and x < 0 else x)
    if a.shape != (n,) and (shape is None or a.shape != shape):
        raise RaytraceError(f"{name}: expected a number or shape {shape or (n,)}, got shape {a.shape}")
    a = a.reshape(n)
    if name == "t_min" and (a < 0).any():
        a = np.where(a < 0, FROM_ORIGIN, a)
    return kernel_array(a)


# Bounds given as numbers, filled out for the kernels and kept for the next
# call with the same size: a fresh (n,) array faults its pages in on first
# write, a visible share of a big call (docs/benchmarks.md, "Ray queries").
# The kernels only read them, and they are never handed out.
_FILLED = {}


_FILLED_MAX = 4                  # arrays kept


_FILLED_MAX_BYTES = 8 << 20      # each


def in_order(scene, rays, answers, trace):
    """The counter rows of a query traced in order (cast/ordering.py) where
    its rays are worth it: ``trace(window's rays, window's answers,
    counter row)`` runs the query's kernel on a window, and ``answers``
    (the call's arrays) get each window's put back.  None where the rays
    are to be traced as given."""
    origins, dirs, t_min, t_max = rays
    n = len(t_min)
    if n < ordering.ORDER_MIN:
        return None
    key = ordering.decide(origins, dirs, n, _prims(scene))
    if key is None:
        return None
    return ordering.trace_in_order(key, trace, rays, _uniform(t_min, t_max), answers, _blocks(n))


def _prims(scene):
    """The primitives a ray scene's structure holds (triangles, spheres)."""
    geo = scene.record[0]
    return geo.tri_v0.shape[0] + geo.sph_center.shape[0]


def _uniform(t_min, t_max):
    """Whether both bounds were given as numbers (_filled's arrays, every
    row the same)."""
    kept = _FILLED.values()
    return any(t_min is a for a in kept) and any(t_max is a for a in kept)


def _filled(n, value):
    key = (n, value.hex())    # by bits: -0.0 is not 0.0, and NaN is NaN
    a = _FILLED.get(key)
    if a is None:
        a = np.full(n, value)
        if a.nbytes <= _FILLED_MAX_BYTES:
            if len(_FILLED) >= _FILLED_MAX:
                _FILLED.clear()
            _FILLED[key] = a
    return a


def _rays(origins, directions, t_min, t_max):
    """Validated kernel arrays (origins, directions, t_min, t_max), the
    rays' leading shape (None for rows), and the origins and directions as
    given, (n, 3) in their own dtype, for answers read after the call
    (RayHits): the kernel arrays may be this thread's buffers (_kernel_rows).
    ``directions`` None: ``origins`` holds (origin, direction) rows of 6.
    float32 origins and directions stay float32, read in place by the
    kernels (kernels/cast.py kernel_rays): both C-contiguous (n, 3) arrays,
    or (n, 6) rows, passed as both; float64 (n, 6) rows are passed as both
    too (ray.widen_rays).  Other layouts are copied (_kernel_rows)."""
    if directions is None:
        rows, shape = _ray_rows("rays", origins, 6)
        o, d = rows[:, :3], rows[:, 3:]
        kept = (rows, rows) if _kernel_ready(rows, _FLOAT32) or _kernel_ready(rows, _FLOAT64) else None
    else:
        o, o_shape = _ray_rows("origins", origins)
        d, d_shape = _ray_rows("directions", directions)
        if o_shape != d_shape and len(o) > 1 and len(d) > 1:
            raise RaytraceError(f"origins and directions differ in shape "
                                f"({o_shape or o.shape} and {d_shape or d.shape})")
        shape = d_shape if len(o) == 1 else o_shape
        if len(o) == 1 and len(d) > 1:     # one origin for every direction
            o = np.broadcast_to(o, d.shape)
        if len(d) == 1 and len(o) > 1:     # one direction for every origin
            d = np.broadcast_to(d, o.shape)
        if len(o) != len(d):
            raise RaytraceError(f"origins and directions differ in length ({len(o)} and {len(d)})")
        kept = ((o, d) if (_kernel_ready(o, _FLOAT64) and _kernel_ready(d, _FLOAT64))
                or (_kernel_ready(o, _FLOAT32) and _kernel_ready(d, _FLOAT32)) else None)
    n = len(d)
    tmin = _interval_end("t_min", t_min, n, shape)
    tmax = _interval_end("t_max", t_max, n, shape)
    if kept is None:
        rows = _rows_of_six(o, d)
        kept = (rows, rows) if rows is not None else _kernel_rows(o, d)
    return (*kept, tmin, tmax), shape, (o, d)


def _rows_of_six(o, d):
    """The C (n, 6) float32 or float64 rows whose first and last 3 columns
    are ``o`` and ``d`` (rays[:, :3] and rays[:, 3:] of one array of rows),
    which the kernels read in place as they read such rows given whole; or
    None."""
    if o.dtype != d.dtype or o.dtype not in (_FLOAT32, _FLOAT64) or o.ndim != 2 \
            or o.shape != d.shape:
        return None
    size = o.itemsize
    if o.strides != (6 * size, size) or d.strides != o.strides \
            or d.__array_interface__["data"][0] != o.__array_interface__["data"][0] + 3 * size:
        return None
    # Its last element is d's last: within memory that d's view spans.
    rows = np.lib.stride_tricks.as_strided(o, (len(o), 6), (6 * size, size),
                                           writeable=o.flags.writeable)
    return rows if _kernel_ready(rows, o.dtype) else None


# Rays that are not C float64 arrays already (float32 for the queries that
# do not read them in place, Open3D's (..., 6) float64 rows, one origin for
# all) are copied for the kernels into scratch rows each thread keeps
# (kernels/cast.py scratch_rows).
def _kernel_rows(o, d):
    """(n, 3) origins and directions as C float64 arrays: each itself when
    it is one, else a copy, into this thread's scratch rows (slot 0
    origins, 1 directions).  float32 and integers convert exactly.  Two
    copies of PARALLEL_COPY_MIN rows or more run on two threads at once
    when the query has two: NumPy's copy lets go of the GIL, and the
    copies of 307,200 rows from (n, 6) rows took 3.3 ms one after the
    other, a third of a 118k-triangle camera query (docs/benchmarks.md,
    "Rays in other layouts")."""
    pair = [o, d]
    jobs = []
    for slot, a in enumerate(pair):
        if not _kernel_ready(a, _FLOAT64):
            pair[slot] = _kernels().scratch_rows(a.shape[0], slot)
            jobs.append(functools.partial(_copy_rows, pair[slot], a))
    if len(jobs) == 2 and len(o) >= PARALLEL_COPY_MIN and _blocks(len(o)) > 1:
        from raytrace.kernels.threads import run_on_threads
        run_on_threads(jobs)
    else:
        for job in jobs:
            job()
    return tuple(pair)


PARALLEL_COPY_MIN = 65_536


def _copy_rows(out, a):
    """out[:] = a, converted.  Column by column when a's rows are not its
    outer stride (Fortran order, one origin broadcast): NumPy's copy of
    such an (n, 3) array walked it three times slower."""
    if abs(a.strides[0]) < abs(a.strides[1]):
        for axis in range(3):
            np.copyto(out[:, axis], a[:, axis], casting="unsafe")
    else:
        np.copyto(out, a, casting="unsafe")


def _check_rays(cnt, rays):
    """After a query kernel: raise RaytraceError naming the first bad ray
    if the kernel found any (kernels/cast.py checks each ray as it reads
    it, instead of a pass of its own before the call)."""
    # One counter row read as a number: any() costs 2-3 us, a share of a
    # call of one ray.
    one_row = cnt.ndim == 2 and cnt.shape[0] == 1
    if cnt[0, BAD_RAYS] if one_row else np.count_nonzero(cnt[..., BAD_RAYS]):
        _name_the_problem(*rays)


# Point queries run in Morton order of a 32^3 grid over the points' bounds
# (a 15-bit key: NumPy's stable argsort of 16-bit keys is a radix sort), so
# neighbouring queries visit the same BVH nodes while they are in cache
# (docs/benchmarks.md, "Ray queries").  Smaller batches gain too little to
# pay for the ordering.
_ORDER_MIN = 20_000


_MORTON_BITS = 5


_SPREAD = np.array([sum(((v >> b) & 1) << (3 * b) for b in range(_MORTON_BITS))
                    for v in range(1 << _MORTON_BITS)], np.uint16)


def _query_points(points):
    """(validated (n, 3) points in the order the kernels take them, the
    permutation that made that order or None)."""
    q = _as_rows("points", points)
    _check_coordinates("points", q)
    if len(q) < _ORDER_MIN:
        return q, None
    # Column by column: NumPy's reductions along axis 0 of an (n, 3) array
    # are much slower.
    lo = np.array([q[:, a].min() for a in range(3)])
    hi = np.array([q[:, a].max() for a in range(3)])
    # (q - lo) / span is in [0, 1] for any span > 0, subnormal too (a scale
    # factor 31 / span would overflow there); a flat axis gets span 1.
    span = np.where(hi > lo, hi - lo, 1.0)
    cell = ((q - lo) / span * ((1 << _MORTON_BITS) - 1)).astype(np.intp)
    key = _SPREAD[cell[:, 0]] | (_SPREAD[cell[:, 1]] << 1) | (_SPREAD[cell[:, 2]] << 2)
    order = np.argsort(key, kind="stable")
    return np.take(q, order, axis=0), order


def _unsorted(a, order):
    """Results for points in _query_points' order, back in the caller's."""
    if order is None:
        return a
    out = np.empty_like(a)
    out[order] = a
    return out


def _check_coordinates(name, arr):
    """Raise RaytraceError naming the first row of NaN, inf or too large values."""
    bad = bad_coordinate_rows(arr)
    if bad is not None and bad[0] == "nonfinite":
        raise RaytraceError(f"{name}[{bad[1]}]: NaN or infinite value ({bad[2]} such rows)")
    if bad is not None:
        raise RaytraceError(f"{name}[{bad[1]}]: a value beyond {MAX_COORD:g} "
                            f"(products of such values overflow; {bad[2]} such rows)")


def _name_the_problem(o, d, tmin, tmax):
    """Raise RaytraceError naming the first bad ray and how many share it
    (o and d may be the same (n, 6) rows: the origin first, the direction
    last)."""
    o, d = (np.asarray(a, np.float64) for a in (o[:, :3], d[:, -3:]))
    _check_coordinates("origins", o)
    _check_coordinates("directions", d)
    zero = (d[:, 0] == 0.0) & (d[:, 1] == 0.0) & (d[:, 2] == 0.0)
    if zero.any():
        raise RaytraceError(f"directions[{int(np.argmax(zero))}]: zero vector (a ray needs a direction)")
    bad = ~(tmax > 0)   # also catches NaN
    if bad.any():
        raise RaytraceError(f"t_max[{int(np.argmax(bad))}]: must be positive (inf allowed), "
                            f"got {tmax[np.argmax(bad)]}")
    bad = ~((tmin >= FROM_ORIGIN) & (tmin < tmax))
    k = int(np.argmax(bad))
    raise RaytraceError(f"t_min[{k}]: must be a number below t_max ({tmax[k]}), got {tmin[k]}")


def kernel_array(a, dtype=np.float64):
    """``a`` as a C-contiguous, aligned, writeable array of ``dtype`` (a copy
    only when it is not one already): a read-only or strided array would
    compile the kernels again for its type."""
    a = np.asarray(a)
    if not _kernel_ready(a, dtype):
        a = np.array(a, dtype=dtype, order="C", copy=True)
    return a


def _kernel_ready(a, dtype):
    """Whether the kernels take array ``a`` as it is: ``dtype``, C-contiguous,
    aligned and writeable."""
    return a.dtype == dtype and a.flags.c_contiguous and a.flags.aligned and a.flags.writeable


# kernels/cast.py, imported at the first query (it imports Numba); kept
# here, as an import statement in a query's path costs a call of one ray
# about 1 us.
_cast = None


def _kernels():
    global _cast
    if _cast is None:
        from raytrace.kernels import cast
        _cast = cast
    return _cast


def _blocks(n, chunk=None):
    """Counter rows: one per thread (kernels/cast.py: each takes chunks of
    rays, or of points, by ticket), fewer when there are fewer chunks than
    threads.  One block runs in the calling thread, without waking Numba's."""
    chunks = -(-n // (chunk or _kernels().CHUNK))
    if chunks <= 1:
        return 1
    import numba
    return min(numba.get_num_threads(), chunks)


def _counter_rows(n):
    """Zeroed counter rows for a query kernel over n rays (kernels/cast.py)."""
    return np.zeros((_blocks(n), _kernels().COLUMNS), np.int64)


def _clock():
    """A query kernel's chunk clock (kernels/cast.py): the first ticket is 0."""
    return np.zeros(1, np.int64)


SHARED_MIN_ROWS = 4096    # 96 KB at most a column: below malloc's 128 KB mmap threshold


def fresh_columns(n, columns):
    """New arrays of n rows, one per (dtype, width) of ``columns`` (8-byte
    dtypes; width 1 makes an (n,) array, else (n, width)), C-contiguous
    views of one allocation.  A query's answers are several arrays of a
    few MB each; glibc's malloc hands each back to the system when it is
    freed (its trim and mmap thresholds follow the largest block freed so
    far), so every call faulted its answers' pages in again: 3,600 faults,
    about 5 ms, in a call of 307,200 rays whose rays took 4.  One block of
    their sum is kept by malloc for the next call (docs/benchmarks.md,
    "Answers in one allocation").  Fewer than SHARED_MIN_ROWS rows are
    arrays of their own: malloc serves such blocks from its heap, which
    faults nothing, and the views of one block took a call of one ray 1.6
    of its 9.3 us."""
    if n < SHARED_MIN_ROWS:
        return [np.empty(n if width == 1 else (n, width), dtype) for dtype, width in columns]
    block = np.empty(n * sum(w for _, w in columns))
    out, start = [], 0
    for dtype, width in columns:
        a = block[start:start + n * width].view(dtype)
        out.append(a if width == 1 else a.reshape(n, width))
        start += n * width
    return out


def _closest(scene, origins, dirs, t_min, t_max, check=True, entries=None):
    """((t, prim, b1, b2), counters) for (n, 3) rays and (n,) bounds in
    ``scene`` (kernels/cast.py ray_scene's); RaytraceError if a ray is bad
    (with ``check``; else it misses).  ``entries``: the prepared scene's
    compiled entry points (kernels/entry.py entry_of), for rays as _rays
    makes them."""
    k = _kernels()
    n = len(origins)
    out = tuple(fresh_columns(n, ((np.float64, 1), (np.int64, 1), (np.float64, 1),
                                  (np.float64, 1))))
    cnt = in_order(scene, (origins, dirs, t_min, t_max), out, lambda rays, answers, row:
                   k.cast_closest(scene, *rays, *answers, row, _clock(), entries))
    if cnt is None:
        cnt = _counter_rows(n)
        k.cast_closest(scene, origins, dirs, t_min, t_max, *out, cnt, _clock(), entries)
    if check:
        _check_rays(cnt, (origins, dirs, t_min, t_max))
    return out, (cnt[0] if len(cnt) == 1 else cnt.sum(axis=0))


def _any_hit(scene, origins, dirs, t_min, t_max, check=True, entries=None):
    """(occluded bool array, counters); RaytraceError if a ray is bad (with
    ``check``; else it is not occluded).  ``entries``: as _closest's."""
    k = _kernels()
    n = len(origins)
    hit = np.empty(n, np.bool_)
    cnt = in_order(scene, (origins, dirs, t_min, t_max), (hit,), lambda rays, answers, row:
                   k.cast_occluded(scene, *rays, *answers, row, _clock(), entries))
    if cnt is None:
        cnt = _counter_rows(n)
        k.cast_occluded(scene, origins, dirs, t_min, t_max, hit, cnt, _clock(), entries)
    if check:
        _check_rays(cnt, (origins, dirs, t_min, t_max))
    return hit, (cnt[0] if len(cnt) == 1 else cnt.sum(axis=0))


def _counters(cnt, n):
    """A query's counters under the renderer's names, made when first read
    (RayHits.stats): a call of one ray is not worth a dictionary."""
    def make():
        from raytrace.renderer.stats import counters_from_rows
        c = counters_from_rows(cnt[None, :])
        return {"rays": n, "prim_tests": c["prim_tests"], "prim_hits": c["prim_hits"],
                "box_tests": c["box_tests"], "nodes_visited": c["nodes_visited"],
                "cells_visited": c["cells_visited"]}
    return make
