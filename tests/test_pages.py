"""small_pages turns NumPy's huge-page advice off inside and restores it,
also when the block raises."""
import pytest

from raytrace.kernels.pages import small_pages

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
