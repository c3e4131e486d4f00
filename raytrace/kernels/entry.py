"""A batch kernel called again and again with arguments of one set of
types, through its compiled entry point, looked up once.

Numba's dispatcher types every argument in Python on every call to find
the compiled version: for a render's stage entries (a Shading record of
some eighty arrays, a wave's buffers) that is about 30 us a call, against
3 us through the entry point.  A wave costs a dozen such calls: a
path-traced render of few samples spent much of its time there, a Whitted
one a few percent at most (docs/benchmarks.md, "Renderer").  The entry
point does not check types: an Entry must only ever be given arguments
of its first call's types (one render's thread's buffers; one prepared
scene's rays of one dtype)."""
try:
    from numba._dispatcher import compute_fingerprint
except ImportError:          # a Numba without it: every call through the dispatcher
    compute_fingerprint = None

from raytrace.kernels.packed import Packed

# Compiled versions found, by kernel and the arguments' fingerprints (the
# key Numba's dispatcher maps to a type): typing the arguments in Python
# to find one takes 0.7-2 ms, so it is done once a process per signature,
# not once per render thread.
_FOUND = {}


class Entry:
    """``kernel`` (a Numba dispatcher) called as ``entry(*args)``.  The
    first call goes through the dispatcher (compiling or loading the
    kernel); later ones through the compiled version that call ran: the
    kernel's only one, or, where a process holds several (a structure's
    ray kernels after another's, `raytrace compare`), the one of these
    arguments' types."""

    __slots__ = ("kernel", "call")

    def __init__(self, kernel):
        self.kernel = kernel
        self.call = None

    def __call__(self, *args):
        if self.call is not None:
            return self.call(*args)
        out = self.kernel(*args)       # compiles or loads it
        self.call = self._compiled(args)
        return out

    def _compiled(self, args):
        overloads = self.kernel.overloads
        if len(overloads) == 1:
            # Read through dict's view: an OrderedDict's own hashes each key
            # as it goes, and a Shading record's type hashes in 0.3 ms.
            return next(iter(dict.values(overloads))).entry_point
        try:
            # Numba fingerprints no Packed: its record's type stands for it.
            key = (self.kernel, tuple(a.numba_type if isinstance(a, Packed) else
                                      compute_fingerprint(a) for a in args))
        except (TypeError, ValueError, NotImplementedError):
            return self.kernel         # an argument Numba fingerprints not
        call = _FOUND.get(key)
        if call is None:
            types = tuple(self.kernel.typeof_pyval(a) for a in args)
            found = [c for sig, c in dict.items(overloads) if sig == types]
            call = _FOUND[key] = found[0].entry_point if found else self.kernel
        return call


def entry_of(kernel, entries):
    """``kernel``'s Entry kept in ``entries`` (a dict of the caller's), made
    at its first use; ``kernel`` itself (its dispatcher) where ``entries``
    is None.  The caller's calls through an entry must give arguments of
    one set of types only (one prepared scene's queries; one render
    thread's buffers): a wrong entry would read the arrays as another
    type."""
    if entries is None:
        return kernel
    entry = entries.get(kernel)
    if entry is None:
        entry = entries[kernel] = Entry(kernel)
    return entry
