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


class Entry:
    """``kernel`` (a Numba dispatcher) called as ``entry(*args)``.  With
    ``lookup`` the first call finds its compiled version by typing the
    arguments in Python (a few hundred microseconds: for an Entry kept
    across many calls, as a prepared scene's); without, it takes the
    kernel's only compiled version, and the dispatcher serves every call
    where there are several (a process that rendered scenes of other
    kinds)."""

    __slots__ = ("kernel", "call", "lookup")

    def __init__(self, kernel, lookup=False):
        self.kernel = kernel
        self.call = None
        self.lookup = lookup

    def __call__(self, *args):
        if self.call is not None:
            return self.call(*args)
        out = self.kernel(*args)       # compiles or loads it
        self.call = self._compiled(args)
        return out

    def _compiled(self, args):
        overloads = self.kernel.overloads
        if self.lookup:
            found = overloads.get(tuple(self.kernel.typeof_pyval(a) for a in args))
        else:
            # The one compiled version is the one the call just ran.  Read
            # through dict's view: an OrderedDict's own hashes each key as it
            # goes, and a Shading record's type hashes in 0.3 ms.
            found = next(iter(dict.values(overloads))) if len(overloads) == 1 else None
        return found.entry_point if found is not None else self.kernel
