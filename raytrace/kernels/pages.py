"""Which pages NumPy asks the kernel for.

NumPy advises the kernel to back arrays of 4 MB and more with 2 MB pages
(madvise).  Where transparent huge pages defragment on that advice (THP
defrag "madvise", this machine's setting and a common default) a fault
may first compact memory to find one.  Loading and flattening a mesh
write each new array once, front to back, and gain nothing from huge
pages.  Flattening (``flatten``, for the command and RayScene alike) runs
without the advice.  The BVH build, whose scattered reads do gain from
fewer TLB misses, keeps it; and so does reading the mesh file, because
the small pages it would free make the build's huge pages cost more than
the read gains (docs/benchmarks.md, "Scene").

Pages never written: ``lazy_zeros``; pages freed but kept: ``trim_heap``.
"""
import mmap
from contextlib import contextmanager

import numpy as np


@contextmanager
def small_pages():
    """NumPy's huge-page advice off for the block, then as it was.  A no-op
    where NumPy has no such switch (it is private: numpy._core.multiarray)."""
    try:
        from numpy._core.multiarray import _set_madvise_hugepage
    except ImportError:
        yield
        return
    before = _set_madvise_hugepage(False)
    try:
        yield
    finally:
        _set_madvise_hugepage(before)


def lazy_zeros(n, dtype):
    """n zeros of ``dtype`` in a private mapping of their own, whose pages,
    until written, read as the system's shared zero page and cost no
    memory (a 2 MB one where huge pages are allowed: a fault each 2 MB).
    np.zeros may take them from the C heap and clear them by writing; a
    shared mapping (mmap's default) gives each page read a page of its own."""
    private = {"flags": mmap.MAP_PRIVATE} if hasattr(mmap, "MAP_PRIVATE") else {}
    pages = mmap.mmap(-1, max(n * np.dtype(dtype).itemsize, 1), **private)
    if hasattr(mmap, "MADV_HUGEPAGE"):
        pages.madvise(mmap.MADV_HUGEPAGE)
    return np.frombuffer(pages, dtype, count=n)


def trim_heap():
    """The C heap's free pages back to the system (glibc's malloc_trim; a
    no-op elsewhere).  glibc gives back the heap's free top only past a
    threshold it raises as big blocks are freed, and free pages below the
    top not at all, so scratch a kernel allocated and freed (the BVH
    builder's bins) stayed resident."""
    import ctypes
    try:
        trim = ctypes.CDLL(None).malloc_trim
    except (AttributeError, OSError, TypeError):
        return
    trim(0)
