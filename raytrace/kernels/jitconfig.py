"""Numba configuration, set before any function is decorated (the kernel
and builder packages import this first).

Numba's on-disk cache keys a function by its own file's timestamp only, so
editing a helper in another file (an intersection test, say) would leave a
stale compiled render kernel in place.  The cache therefore lives in a
directory named by a hash of every kernel source file: any change to any
kernel starts a fresh cache.  NUMBA_CACHE_DIR, if the user sets it, says
where that directory goes (in place of ~/.cache/raytrace): used as the
cache itself, it kept entries across upgrades, so a kernel compiled
against an older helper loaded, and an index naming a record type since
removed failed to unpickle (AttributeError) before Numba checked anything.

A damaged cache file is found and compiled again (kernel_cache.py); a cache
directory that cannot be written (read-only, or no home directory, as for
`nobody`) means kernels compile uncached, with one warning line, where
Numba would fail with "no locator available".
"""
import os
import tempfile
import threading
from pathlib import Path

import numba

from raytrace.kernels import compile_clock  # noqa: F401 -- counts from the first kernel on
from raytrace.kernels.cachedir import cache_dir
from raytrace.kernels.inline_copy import install as _install_inline_copy


def _unwritable(path):
    """Why kernels cannot be cached in ``path``, or None if they can."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".probe.", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


# Helpers get no machine code of their own: the kernel that links their IR
# makes it, once (linked_only.py).  RAYTRACE_LINKED_ONLY=0 leaves Numba's
# compile as it is (to compare, or should a Numba release misbehave).
if os.environ.get("RAYTRACE_LINKED_ONLY", "") != "0":
    from raytrace.kernels.linked_only import install as _install_linked_only
    _install_linked_only()

# Numba copies an inlined stage's IR one block at a time, the whole scope
# with each; ours are copied once (inline_copy.py: the same IR, sooner).
_install_inline_copy()

numba.config.CACHE_DIR = str(cache_dir(numba.__version__))
_why = _unwritable(Path(numba.config.CACHE_DIR))
# Whether kernels are cached (kernels/jit.py's cache=).
CACHING = _why is None
if CACHING:
    from raytrace.kernels.kernel_cache import install
    install(numba.config.CACHE_DIR)
else:
    from raytrace.kernels.kernel_cache import warn
    warn(f"kernel cache {numba.config.CACHE_DIR}: cannot write ({_why}); compiling "
         "without a cache (set NUMBA_CACHE_DIR to a writable directory)")

# The kernels run on threads.py's threads, not Numba's; Numba's thread count
# (numba.set_num_threads) holds the command's --threads, and its threading
# layer starts only to hold it: the workqueue, the lightest to start
# (OpenMP's pool would start threads that never run a kernel).
if not os.environ.get("NUMBA_THREADING_LAYER"):
    numba.config.THREADING_LAYER = "workqueue"
# One batch kernel at a time in a process: each uses every render thread,
# and Dask's tasks, which may share a process, would oversubscribe the cores.
KERNEL_LOCK = threading.Lock()
