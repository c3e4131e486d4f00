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
  code is one loop again, as fast as before (docs/design.md, "The kernel
  layer").
"""
JIT = dict(cache=True, error_model="numpy", _nrt=False, forceinline=True)
PARALLEL = dict(JIT, parallel=True, forceinline=False)
# Implementations of @overload'ed dispatch functions: one-line wrappers,
# not cached (their closures hold dispatchers, which pickle differently in
# every process, so a cached entry would never be found again).
OVERLOAD = dict(error_model="numpy", _nrt=False, forceinline=True)
