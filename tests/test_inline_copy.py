"""Numba's copy of an inlined stage's IR, made once (kernels/inline_copy.py):
the same IR and code as Numba's own copy, block by block, made in one pass."""
import copy
import io
import re
from collections import namedtuple

import numpy as np
from numba import njit
from numba.core import inline_closurecall, ir
from numba.core.compiler import run_frontend

from raytrace.kernels import (
    inline_copy,
    jitconfig,  # noqa: F401 -- installs inline_copy, as the kernels do
)
from raytrace.kernels.bounces import _first_generation, generation_buffers, shade_generation


def test_installed_on_this_numba():
    """The Numba installed copies inlined IR as this patches: if a release
    changes it, install() leaves Numba alone and this says so."""
    assert inline_copy.installed()
    assert inline_closurecall.InlineWorker.inline_ir is inline_copy._inline_ir
    assert inline_closurecall.copy is inline_copy._Copy


def _dump(block):
    out = io.StringIO()
    block.dump(out)
    return out.getvalue()


def test_a_copy_is_numbas_block_for_block_in_one_pass():
    """Each block copied with a memo of its own (Numba) or one memo for all
    (here): the same statements, but Numba's copies the function's whole
    scope with every block, this one copies each variable once."""
    original = run_frontend(shade_generation.py_func)
    blocks = original.blocks
    memos = [{} for _ in blocks]
    numbas = {label: copy.deepcopy(b, memo) for (label, b), memo in zip(blocks.items(), memos)}
    inline_copy._memos.by_scope = {}
    try:
        ours = {label: inline_copy._Copy.deepcopy(b) for label, b in blocks.items()}
        shared = inline_copy._memos.by_scope
    finally:
        inline_copy._memos.by_scope = None
    assert len(blocks) > 20
    for label, block in blocks.items():
        assert _dump(ours[label]) == _dump(numbas[label]) == _dump(block)
    # One scope for all the copied blocks, as in the original; Numba's: one a block.
    assert len({id(b.scope) for b in blocks.values()}) == 1
    assert len({id(b.scope) for b in ours.values()}) == 1
    assert len({id(b.scope) for b in numbas.values()}) == len(blocks)
    # A copy, not the original's objects.
    scope = next(iter(ours.values())).scope
    assert scope is not next(iter(blocks.values())).scope
    copied_vars = [v for b in ours.values() for v in b.find_insts(ir.Assign)]
    original_vars = {id(a) for b in blocks.values() for a in b.find_insts(ir.Assign)}
    assert copied_vars and not any(id(a) in original_vars for a in copied_vars)
    # Objects copied: Numba's copy holds the whole scope with each block
    # (39 blocks, 788 variables: 34,747 objects); this one holds each
    # block's own objects and the scope once (4,111).
    n_vars = len(next(iter(blocks.values())).scope.localvars._con)
    assert all(len(m) > n_vars for m in memos)
    ours_copied = sum(len(m) for m in shared.values())
    assert ours_copied < sum(len(m) - n_vars for m in memos) + 2 * n_vars


_Wave = namedtuple("_Wave", ["origins", "dirs", "row"])


def _caller():
    """A fresh function inlining one of our STAGE functions (Numba's inline
    'always')."""
    @njit(cache=False)
    def first(wave, n, gen):
        return _first_generation(wave, n, gen)
    return first


def _llvm(fn, *args):
    fn(*args)
    text = next(iter(fn.inspect_llvm().values()))
    # Names differ by a function's unique id and block labels by Numba's
    # count of labels made in the process (and comments' padding with them):
    # the bodies are compared.
    text = re.sub(r"_ZN[\w$.]+|\$\d+|\.\d+\b|\bB\d+", "#", text)
    return re.sub(r"[ \t]+", " ", re.sub(r";[^\n]*", "", text))


def test_an_inlined_stage_compiles_to_numbas_ir(monkeypatch):
    """A function inlining a stage of ours compiles through this module's
    copy, to the LLVM IR Numba's own copy gives, and runs."""
    rng = np.random.default_rng(3)
    wave = _Wave(rng.normal(size=(5, 3)), rng.normal(size=(5, 3)), np.arange(5) + 10)
    args = (wave, 5, generation_buffers(5))
    used = []
    deepcopy = inline_copy._Copy.deepcopy

    def spy(x, memo=None):
        used.append(memo is None and inline_copy._memos.by_scope is not None)
        return deepcopy(x, memo)

    monkeypatch.setattr(inline_copy._Copy, "deepcopy", staticmethod(spy))
    ours = _llvm(_caller(), *args)
    assert used and all(used)
    gen = args[2]
    assert np.array_equal(gen.origins, wave.origins) and np.array_equal(gen.row, wave.row)
    assert np.all(gen.weight == 1.0) and np.all(gen.key == 0)
    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_ir",
                        inline_copy._numba["inline_ir"])
    monkeypatch.setattr(inline_closurecall, "copy", copy)
    used.clear()
    numbas = _llvm(_caller(), *args)
    assert not used
    assert ours == numbas
