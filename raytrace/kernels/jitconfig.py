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
"""
import os
import threading

import numba

from raytrace.kernels.cachedir import cache_dir

numba.config.CACHE_DIR = str(cache_dir(numba.__version__))

# Numba picks OpenMP when it can, and GNU OpenMP's parallel-region start
# measured 8 ms per kernel call here (threads asleep between calls) against
# 0.09 ms for Numba's own workqueue: 0.26 s against 0.05 s for a
# 640x480 teapot rendered in 32 bands for the progress bar, and 1.93 s
# against 1.74 s with soft shadows.  The workqueue cannot run kernels from
# several Python threads at once (it aborts the process): Dask's tasks,
# which may share a process, take KERNEL_LOCK around their kernel calls.
if not os.environ.get("NUMBA_THREADING_LAYER"):
    numba.config.THREADING_LAYER = "workqueue"
# One parallel kernel at a time in a process; each uses every render thread.
KERNEL_LOCK = threading.Lock()
