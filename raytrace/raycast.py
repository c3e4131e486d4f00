"""Batch ray casting glue: arrays in, per-ray results and counters out.

The kernels take per-block counter rows (they cannot allocate); this module
allocates them and sums the counters.
"""
import numpy as np

# Rays are split into this many blocks per thread, each with its own
# counter row: enough blocks that uneven rays balance.
BLOCKS_PER_THREAD = 16


def _blocks(n):
    import numba
    return max(1, min(n, BLOCKS_PER_THREAD * numba.get_num_threads()))


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
