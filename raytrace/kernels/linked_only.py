"""Kernel helpers never turned into machine code of their own.

Numba compiles every function as a library of its own: typed, lowered,
optimised, linked with its callees' libraries, optimised again as a whole
module, then handed to LLVM's JIT, which makes its machine code.  A caller
links that module's IR in and does the same over all of it.  Our per-ray
and per-stage helpers (kernels/jit.py's JIT, STAGE and OVERLOAD options)
have neither a Python nor a C wrapper: nothing can call their machine code,
and every kernel that uses them links and inlines their IR
(``forceinline``).  Their code generation was made at every level of
calls, then never run: 0.35-0.6 s of the BVH's two packet kernels' 7.3-7.4
s cold compile, 0.5-0.7 s of a first `raytrace teapot`'s (docs/benchmarks.md,
"Helpers without machine code").

Here a library of ours with no wrapper is linked and optimised exactly as
Numba's finalize does it, and marked finished without going to the JIT:
the kernel entry that links it makes the machine code, once.  Cached, such
a library is saved as its optimised IR (Numba's "bitcode" entry) and loaded
back as IR, with no code made on load.  The kernels' code is not Numba's
to the byte (Numba linked the IR its code generation had prepared), but
it runs as fast (1.000-1.007x, one thread, the suite's 1k rows) and gives
the same bits: without fast-math flags LLVM keeps every operation's IEEE
result (tests/test_linked_only.py compares answers and an image with
Numba's own compile).

Only libraries whose functions are raytrace's (mangled names starting with
``_ZN8raytrace``) are treated so; any other Numba user's functions in the
process compile as Numba has them.  ``install`` patches Numba's JIT code
library only where it has the methods this replaces (Numba 0.68); else it
does nothing, and kernels compile as Numba has them, only slower.
"""
from numba.core import codegen

_OURS = "_ZN8raytrace"
# Numba's wrappers' names (funcdesc.py: the C wrapper "cfunc.<name>", the
# Python one <name> in the nested namespace "cpython").
_WRAPPERS = ("_ZN7cpython", "_Z7cpython", "cfunc.")

_numba = {}


def _linked_only(module):
    """Whether an LLVM module is a helper of ours: it defines a function of
    raytrace's and no wrapper through which Python or C could call it."""
    ours = False
    for fn in module.functions:
        if fn.is_declaration:
            continue
        if fn.name.startswith(_WRAPPERS):
            return False
        ours = ours or fn.name.startswith(_OURS)
    return ours


def _finalize(self):
    """JITCodeLibrary.finalize, for a helper of ours: its callees linked in
    and the module optimised as Numba's finalize does, then no JIT."""
    if not _linked_only(self._final_module):
        return _numba["finalize"](self)
    from numba.core.compiler_lock import require_global_compiler_lock
    require_global_compiler_lock()
    self._raise_if_finalized()
    seen = set()
    for library in self._linking_libraries:
        if library not in seen:
            self._reload_init.update(library._reload_init)
            seen.add(library)
            self._final_module.link_in(library._get_module_for_linking(), preserve=True)
    self._optimize_final_module()
    self._final_module.verify()
    self._finalized = True
    self._ir_only = True


def _serialize(self):
    """A helper's cache entry: its IR (Numba's "bitcode" form); others as
    Numba saves them (machine code and IR)."""
    if getattr(self, "_ir_only", False):
        return (self.name, "bitcode", self._final_module.as_bitcode())
    return _numba["serialize"](self)


def _unserialize(cls, codegen_, state):
    """A cached helper loaded as IR only, with no machine code made (Numba
    would compile a bitcode entry on load)."""
    name, kind, data = state
    if kind == "bitcode":
        import llvmlite.binding as ll
        module = ll.parse_bitcode(data)
        if _linked_only(module):
            self = codegen_.create_library(name)
            self._final_module = module
            self._finalized = True
            self._ir_only = True
            return self
    return _numba["unserialize"](cls, codegen_, state)


def _set_env(self, env_name, env):
    """JITCPUCodegen.set_env, except for a helper's environment, which is in
    no compiled module: nothing to set (the kernel it is linked into has
    its own)."""
    if self._engine.get_global_value_address(env_name) == 0:
        return
    _numba["set_env"](self, env_name, env)


def install():
    """Patch Numba's JIT code library (once), if it has the methods this
    module replaces."""
    if _numba:
        return
    library, base, jit = (getattr(codegen, n, None) for n in
                          ("JITCodeLibrary", "CPUCodeLibrary", "JITCPUCodegen"))
    needed = ((library, ("finalize", "_raise_if_finalized", "_get_module_for_linking")),
              (base, ("serialize_using_object_code", "_unserialize")),
              (jit, ("set_env",)))
    if not all(owner is not None and all(hasattr(owner, n) for n in names)
               for owner, names in needed):
        return
    _numba.update(finalize=library.finalize, serialize=base.serialize_using_object_code,
                  unserialize=base._unserialize.__func__, set_env=jit.set_env)
    library.finalize = _finalize
    base.serialize_using_object_code = _serialize
    base._unserialize = classmethod(_unserialize)
    jit.set_env = _set_env


def installed():
    """Whether install patched Numba (tests)."""
    return bool(_numba)
