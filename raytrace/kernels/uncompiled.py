"""Mesh readers' kernels run as Python, uncompiled, on inputs too small to
repay their compile.

A small mesh file is read (scene/formats/objtext.py: OBJ and ASCII STL
lines; scene/formats/polygons.py: a binary PLY's mixed polygons), welded
(scene/weld.py) and its normals split at creases (scene/creases.py) by
kernels that take 1.5-2 s, 0.4 s, 0.8 s and 2.5 s to compile cold and
milliseconds to run compiled; the same functions run by Python take about
16 us a corner to split, 25 us a row to weld, and read 1.5-2 MB of OBJ a
second.  So on a first run, for a mesh of at most ``UNCOMPILED_MAX`` rows
or corners (0.1-0.2 s of Python), they run as Python: the same code,
nothing compiled for it, and the LLVM intrinsics they call
(kernels/lowlevel.py) by Python versions here.  Once a kernel is compiled
(in this process or the kernel cache: ``raytrace warmup``, or a larger
mesh read before), it is used at every size.

The functions give the compiled kernels' answers bit for bit
(tests/test_uncompiled.py): they read float64 and integer arrays (a file's
bytes widened to int64: NumPy's uint8 scalars wrap where the compiled
kernel's integers widen), and their arithmetic is IEEE's either way
(``math.atan2`` is libm's in both; NumPy's own ``arctan2`` is not).
Integer arithmetic that wraps (a hash) wraps the same on NumPy's scalars,
under ``np.errstate(over="ignore")``.
"""
import contextlib
import threading
import types

import numpy as np

from raytrace.kernels.limits import UNCOMPILED_MAX

_python = {}
_made = threading.RLock()


def _stand_ins():
    """Python versions of the LLVM intrinsics (kernels/lowlevel.py) the
    kernels run so call, by id (a kernel's globals hold arrays, which do
    not hash)."""
    from raytrace.kernels import lowlevel as low
    u64, word = np.uint64, (1 << 64) - 1

    def load_word(arr, i):
        # arr: a file's bytes widened to int64 (formats/obj.py says why).
        return u64(int.from_bytes(arr[i:i + 8].astype(np.uint8).tobytes(), "little"))

    def trailing_zeros(x):
        x = int(x) & word
        return (x & -x).bit_length() - 1 if x else 64

    def wide_product(a, b):
        product = int(a) * int(b)
        return u64(product >> 64), u64(product & word)

    return {
        id(low.prefetch): lambda arr, i: None,        # a hint: nothing to do in Python
        id(low.frame_array): lambda size, dtype: np.empty(size, dtype),
        id(low.load_word): load_word,
        id(low.trailing_zeros): trailing_zeros,
        id(low.leading_zeros): lambda x: 64 - (int(x) & word).bit_length(),
        id(low.wide_product): wide_product,
        id(low.double_from_bits): lambda bits: np.array([bits], u64).view(np.float64)[0],
    }


def as_python(kernel):
    """``kernel``'s Python function, with every compiled function it calls
    (by a module-level name) replaced by its own Python function, so a call
    compiles nothing.  Under a lock: an ASCII STL's weld asks for its
    kernel on a thread of its own, and a function half made (its names not
    yet swapped) would call an intrinsic from Python."""
    func = getattr(kernel, "py_func", kernel)
    with _made:
        if func in _python:
            return _python[func]
        from numba.core.registry import CPUDispatcher
        stand_ins = _stand_ins()
        names = dict(func.__globals__)
        for name in func.__code__.co_names:
            value = names.get(name)
            if isinstance(value, CPUDispatcher):
                names[name] = as_python(value)
            elif id(value) in stand_ins:
                names[name] = stand_ins[id(value)]
        _python[func] = types.FunctionType(func.__code__, names, func.__name__, func.__defaults__,
                                           func.__closure__)
        return _python[func]


_always = threading.local()


@contextlib.contextmanager
def compiled_always():
    """Within, on this thread, every kernel runs compiled: ``raytrace
    warmup`` compiles, on a tiny mesh, what any file's reading will use."""
    _always.on = True
    try:
        yield
    finally:
        _always.on = False


def runs_compiled(kernel, n):
    """Whether a call of ``kernel`` on n rows or corners should run
    compiled: it is compiled already (in this process or in the kernel
    cache), n is larger than UNCOMPILED_MAX, or within compiled_always."""
    if n > UNCOMPILED_MAX or kernel.signatures or getattr(_always, "on", False):
        return True
    from raytrace.kernels.cachedir import has_cache_entries
    return has_cache_entries(kernel)


def chosen(kernel, n):
    """``kernel`` itself, or where runs_compiled says not, its Python
    function, called as the compiled one behaves: wrapping integers and
    division by zero without a warning (the kernels' error model is
    NumPy's)."""
    if runs_compiled(kernel, n):
        return kernel
    python = as_python(kernel)

    def call(*args):
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            return python(*args)
    return call


def file_bytes(kernel, data):
    """A file's bytes (uint8) as ``kernel``, one ``chosen`` returned, reads
    them: as they are compiled, widened to int64 as Python, where NumPy's
    uint8 scalars would wrap (or refuse a Python int too large) where the
    compiled kernel's integers widen."""
    return data if hasattr(kernel, "py_func") else data.astype(np.int64)
