"""Which pages NumPy asks the kernel for.

NumPy advises the kernel to back arrays of 4 MB and more with 2 MB pages
(madvise).  Where transparent huge pages defragment on that advice (THP
defrag "madvise", this machine's setting and a common default) a fault
may first compact memory to find one.  Loading and flattening a mesh
write each new array once, front to back, and gain nothing from huge
pages.  Flattening (``flatten``, for the command and RayScene alike) runs
without the advice: the 4.2M-triangle PLY's flatten 1.24-1.39 -> 0.84 s,
its whole command 4.09-4.28 -> 3.89-3.90 s (medians of 4, three runs);
the --detail 256 teapot's the same (0.62 -> 0.64 s).
The BVH build, whose scattered reads do gain from fewer TLB misses (1.3 s
with, 1.5-1.6 s without), keeps it; and so does reading the mesh file
(0.59-0.88 -> 0.46-0.48 s without), because the small pages it then
frees made the build's huge pages cost more than that (1.38 -> 1.95 s).
"""
from contextlib import contextmanager


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
