"""Numba's copy of an inlined function's IR, made in one pass.

A STAGE function (kernels/jit.py) is inlined by Numba into its caller, and
``InlineWorker.inline_ir`` copies the callee's IR twice first, block by
block, each block by ``copy.deepcopy`` with a memo of its own.  Every
variable in a block points at the function's scope, which holds every
variable of the function, so each block's copy copied the whole scope
again: the time grew as blocks times variables.  That was 0.25 s of the
BVH's packet kernels' 6.9 s cold compile (11 inlined calls) and 0.1 s of
the mirrors' shading entry's (docs/benchmarks.md, "Inlined IR copied once").

Here the blocks of one copy share one memo: the scope and each variable
are copied once, and the copy shares its objects between blocks as the
original does (Numba's own IR has one scope for all blocks of a function).
The IR that results, and so the LLVM IR and the machine code, are Numba's:
compared over every function compiled for the teapot's ray kernels and
shading stages, the mirrors', textures' and the path tracer's.

Only the inlining of raytrace's functions is changed; ``install`` does
nothing on a Numba whose inlining module has no ``InlineWorker.inline_ir``
or does not copy through the ``copy`` module.
"""
import copy
import threading

from numba.core import inline_closurecall, ir

_numba = {}
# The memos of the copies inline_ir is making on this thread, by the
# original scope (None outside inline_ir of one of ours).
_memos = threading.local()


class _Copy:
    """inline_closurecall's ``copy`` module: deepcopy of a block, within an
    inline_ir of ours, shares one memo with the other blocks of its scope."""
    copy = staticmethod(copy.copy)

    @staticmethod
    def deepcopy(x, memo=None):
        memos = getattr(_memos, "by_scope", None)
        if memo is None and memos is not None and isinstance(x, ir.Block):
            memo = memos.setdefault(id(x.scope), {})
        return copy.deepcopy(x, memo)


def _ours(callee_ir):
    return getattr(callee_ir.func_id, "modname", "").startswith("raytrace.")


def _inline_ir(self, caller_ir, block, i, callee_ir, *args, **kwargs):
    """InlineWorker.inline_ir, its copies of a callee of ours made with one
    memo a scope (the originals it copies stay alive throughout, so their
    ids name them)."""
    if not _ours(callee_ir):
        return _numba["inline_ir"](self, caller_ir, block, i, callee_ir, *args, **kwargs)
    saved = getattr(_memos, "by_scope", None)
    _memos.by_scope = {}
    try:
        return _numba["inline_ir"](self, caller_ir, block, i, callee_ir, *args, **kwargs)
    finally:
        _memos.by_scope = saved


def install():
    """Patch Numba's inlining (once), if it has what this module replaces."""
    if _numba:
        return
    worker = getattr(inline_closurecall, "InlineWorker", None)
    if getattr(inline_closurecall, "copy", None) is not copy \
            or not hasattr(worker, "inline_ir"):
        return
    _numba["inline_ir"] = worker.inline_ir
    worker.inline_ir = _inline_ir
    inline_closurecall.copy = _Copy


def installed():
    """Whether install patched Numba (tests)."""
    return bool(_numba)
