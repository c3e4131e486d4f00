"""Batch ray casting glue: arrays in, per-ray results and counters out.

The kernels take per-block counter rows (they cannot allocate); this module
allocates them, sums the counters, and hands the kernels arrays of one
dtype, C order and writeable, whatever the caller passed: a read-only or
strided array would otherwise compile the kernels again for its type.
"""
import numpy as np


def kernel_array(a, dtype=np.float64):
    """``a`` as a C-contiguous, aligned, writeable array of ``dtype`` (a copy
    only when it is not one already)."""
    a = np.asarray(a)
    if a.dtype != dtype or not (a.flags.c_contiguous and a.flags.aligned and a.flags.writeable):
        a = np.array(a, dtype=dtype, order="C", copy=True)
    return a


def _blocks(n):
    """Counter rows: one per thread (kernels/cast.py interleaves chunks of
    rays between them), fewer when there are fewer chunks than threads."""
    import numba

    from .kernels.cast import CHUNK
    return max(1, min(numba.get_num_threads(), -(-n // CHUNK)))


def closest(geo, acc, origins, dirs, t_max):
    """Returns ((t, prim, b1, b2), counters) for (n, 3) rays and (n,) t_max."""
    from .kernels.cast import cast_closest
    from .kernels.counters import N_COUNTERS
    n = len(origins)
    out = (np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n))
    cnt = np.zeros((_blocks(n), N_COUNTERS), np.int64)
    cast_closest(geo, acc, kernel_array(origins), kernel_array(dirs), kernel_array(t_max),
                 *out, cnt)
    return out, cnt.sum(axis=0)


def any_hit(geo, acc, origins, dirs, t_max):
    """Returns (occluded bool array, counters)."""
    from .kernels.cast import cast_occluded
    from .kernels.counters import N_COUNTERS
    n = len(origins)
    hit = np.empty(n, np.bool_)
    cnt = np.zeros((_blocks(n), N_COUNTERS), np.int64)
    cast_occluded(geo, acc, kernel_array(origins), kernel_array(dirs), kernel_array(t_max),
                  hit, cnt)
    return hit, cnt.sum(axis=0)
