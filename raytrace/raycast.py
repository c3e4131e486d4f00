"""Batch ray casting glue: arrays in, per-ray results and counters out.

The kernels take per-block counter rows (they cannot allocate); this module
allocates them and sums the counters.
"""
import numpy as np


def _blocks(n):
    """Counter rows: one per thread (kernels/cast.py interleaves chunks of
    rays between them), fewer when there are fewer chunks than threads."""
    import numba

    from .kernels.cast import CHUNK
    return max(1, min(numba.get_num_threads(), -(-n // CHUNK)))


def closest(geo, acc, origins, dirs, t_max):
    """Returns ((t, prim, b1, b2), counters) for float64 (n, 3) rays and (n,) t_max."""
    from .kernels.cast import cast_closest
    from .kernels.counters import N_COUNTERS
    n = len(origins)
    out = (np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n))
    b = _blocks(n)
    cnt = np.zeros((b, N_COUNTERS), np.int64)
    cast_closest(geo, acc, np.ascontiguousarray(origins, np.float64),
                 np.ascontiguousarray(dirs, np.float64), np.ascontiguousarray(t_max, np.float64),
                 *out, cnt)
    return out, cnt.sum(axis=0)


def any_hit(geo, acc, origins, dirs, t_max):
    """Returns (occluded bool array, counters)."""
    from .kernels.cast import cast_occluded
    from .kernels.counters import N_COUNTERS
    n = len(origins)
    hit = np.empty(n, np.bool_)
    b = _blocks(n)
    cnt = np.zeros((b, N_COUNTERS), np.int64)
    cast_occluded(geo, acc, np.ascontiguousarray(origins, np.float64),
                  np.ascontiguousarray(dirs, np.float64), np.ascontiguousarray(t_max, np.float64),
                  hit, cnt)
    return hit, cnt.sum(axis=0)
