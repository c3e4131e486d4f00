"""small_pages turns NumPy's huge-page advice off inside and restores it,
also when the block raises; lazy_zeros are zeros of the kernels' own
type whose unwritten pages cost no memory; trim_heap runs anywhere."""
import pickle
import sys

import numba
import numpy as np
import pytest

from raytrace.kernels.pages import lazy_zeros, small_pages, trim_heap

multiarray = pytest.importorskip("numpy._core.multiarray")


def advice():
    """NumPy's current setting (the switch returns the one it replaces)."""
    now = multiarray._set_madvise_hugepage(True)
    multiarray._set_madvise_hugepage(now)
    return now


@pytest.mark.parametrize("before", [True, False])
def test_off_inside_restored_after(before):
    multiarray._set_madvise_hugepage(before)
    try:
        with small_pages():
            assert advice() is False
        assert advice() is before
        with pytest.raises(KeyError):
            with small_pages():
                raise KeyError("inside")
        assert advice() is before
    finally:
        multiarray._set_madvise_hugepage(True)


def test_lazy_zeros_are_an_ordinary_array():
    a = lazy_zeros(5, np.int64)
    assert a.shape == (5,) and a.dtype == np.int64 and not a.any()
    assert a.flags.c_contiguous and a.flags.writeable
    # The type the kernels were compiled for: no second compile.
    assert numba.typeof(a) == numba.typeof(np.zeros(5, np.int64))
    a[1] = 3
    assert pickle.loads(pickle.dumps(a)).tolist() == [0, 3, 0, 0, 0]
    assert lazy_zeros(0, np.int64).shape == (0,)


def _resident_kib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_lazy_zeros_read_cost_no_memory():
    a = lazy_zeros(1 << 23, np.int64)       # 64 MiB
    before = _resident_kib()
    assert a[::512].sum() == 0              # every 4 KB page read
    assert _resident_kib() - before < 16 << 10


def test_trim_heap_runs():
    trim_heap()
