"""Seconds this process has spent compiling kernels: Numba's
"numba:compile" events, the outermost of each thread's only (a kernel's
compile holds its callees').  Registered when the kernel packages first
import Numba (jitconfig.py), so a phase that compiles on first use (a
mesh file's reader and shading normals) can report that time as compile
time, not as its own.  A kernel loaded from the on-disk cache fires no
event.
"""
import threading
import time

import numba.core.event as event

_total = [0.0]
_thread = threading.local()


class _Clock(event.Listener):
    def on_start(self, ev):
        depth = getattr(_thread, "depth", 0)
        if depth == 0:
            _thread.started = time.perf_counter()
        _thread.depth = depth + 1

    def on_end(self, ev):
        _thread.depth -= 1
        if _thread.depth == 0:
            _total[0] += time.perf_counter() - _thread.started


def seconds():
    """Compile seconds so far in this process."""
    return _total[0]


event.register("numba:compile", _Clock())
