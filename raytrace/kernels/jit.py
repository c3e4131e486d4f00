"""Compile options shared by every kernel.

- ``error_model="numpy"``: 1/0 is inf, not an exception; the slab test
  relies on it.  No fastmath: it would let LLVM assume there is no inf or
  NaN, and the slab and watertight tests use both.
- ``_nrt=False``: no reference counting.  Per-ray functions only read
  arrays their caller keeps alive; without the runtime an array argument
  costs no atomic increment and decrement.  The price: kernels cannot
  allocate, so scratch (counters, stacks) is passed in or lives in the
  frame (``lowlevel.frame_array``).
- Every function is compiled on its own by Numba (no Numba-level
  ``inline="always"``), so a kernel's compile costs its own lines, not
  those of everything it calls copied into it; ``forceinline`` then has
  LLVM inline the compiled calls (its ``alwaysinline``), so the machine
  code is one loop again, as fast as before (docs/design.md, "Compile
  time").
- No Python wrappers (``no_cpython_wrapper``, ``no_cfunc_wrapper``): a
  per-ray function is only ever called from compiled code, and Numba
  otherwise builds and compiles two wrappers for each, a sizeable share of
  a cold compile (docs/benchmarks.md, "Kernels").  A thread's share of a
  batch kernel, called from Python (``BLOCK``), keeps its wrapper, and
  takes its records of arrays packed (packed.py), which that wrapper
  unboxes as one word; a test calling a per-ray function directly uses
  ``python_callable``.
- No ``parallel=True``: threads.py runs a kernel's shares on Python
  threads, where a ``prange`` loop would compile a parallel wrapper of its
  own for every type of its arguments.
"""
from numba import njit

from raytrace.kernels.jitconfig import CACHING

JIT = dict(cache=CACHING, error_model="numpy", _nrt=False, forceinline=True,
           no_cpython_wrapper=True, no_cfunc_wrapper=True)
# A thread's share of a batch kernel (a loop over chunks of rays or points
# taken by ticket): called from Python on each of a call's threads
# (threads.py), so it has its wrapper and releases the GIL, and stays a
# call, not inlined.
BLOCK = dict(JIT, forceinline=False, no_cpython_wrapper=False, nogil=True)
# A stage with one or two callers (the renderer's stage entries,
# kernels/wavefront.py and bounces.py): inlined by Numba into each, so it
# has no library of its own that LLVM optimises and emits, only for the
# entry to link in and optimise again (docs/design.md, "Compile time").
STAGE = dict(JIT, inline="always")
# Implementations of @overload'ed dispatch functions: one-line wrappers,
# not cached (their closures hold dispatchers, which pickle differently in
# every process, so a cached entry would never be found again).
OVERLOAD = dict(error_model="numpy", _nrt=False, forceinline=True,
                no_cpython_wrapper=True, no_cfunc_wrapper=True)

# Structure builders, called from Python on whole arrays: they allocate, so
# they keep the runtime; numpy's error model for the smaller code (every
# division in them is guarded).  A builder's helper needs no wrapper.
BUILD = dict(cache=CACHING, error_model="numpy", no_cfunc_wrapper=True)
BUILD_STEP = dict(BUILD, no_cpython_wrapper=True)


def python_callable(kernel):
    """``kernel`` (an ``@njit(**JIT)`` function, or a Python function an
    @overload compiles as its implementation) compiled again with its
    Python wrapper, for a test or bench that calls it directly.  Not cached:
    the cache keys an entry by signature, not by these options, so the
    wrapped and unwrapped compiles would overwrite each other's entries."""
    options = dict(JIT, cache=False, no_cpython_wrapper=False, no_cfunc_wrapper=False)
    return njit(**options)(getattr(kernel, "py_func", kernel))
