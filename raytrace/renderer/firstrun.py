"""The one line a cold kernel cache earns on stderr:

    compiling kernels for teapot: bvh, hard shadows (first run only, about 9 s)

Numba fires its "numba:compile" event only when it really compiles: a
kernel found in the on-disk cache is loaded without one.  So the line is
printed exactly when a wait starts, once per process, and never on a warm
run.  ``RAYTRACE_QUIET=1`` (or the command's ``-q``) silences it.
"""
import contextlib
import functools
import os
import sys
import threading

from raytrace.kernels.cachedir import has_cache_entries
from raytrace.kernels.limits import BYTES_PER_ROW, UNCOMPILED_MAX

# Seconds a cold compile takes on the issues' 2-core machine (AMD EPYC with
# AVX-512; docs/benchmarks.md, "Cold start" and its 2026-11-28 run of
# `python bench/coldstart.py`), rounded up: the builder and the render
# kernel for each structure, then what mirrors and glass or textures add.
RENDER_S = {"none": 6, "bvol": 6, "bvh": 8, "grid": 6, "kdtree": 6}
BOUNCES_S = 3
TEXTURES_S = 2
# A new variant of a kernel already in the cache (soft shadows after hard,
# another structure's render kernel): the "then ..." rows of that table.
VARIANT_S = 4
# A cold path-traced render, whatever its structure: the path tracer's stage,
# compiled in the second process, outlasts the structure's kernels (9.7 s
# with the BVH's packet closest-hit kernel, 2026-11-28).
PATH_S = 10
# A mesh file's reader and shading normals' kernels, compiled as it loads
# (the weld, the crease split's fan kernels; an OBJ's parser 1.5 s more),
# unless the file is small: then they run as Python (kernels/uncompiled.py).
MESH_S = 3
SMALL_MESH_BYTES = UNCOMPILED_MAX * BYTES_PER_ROW
# A RayScene's first query: its structure's builder and the query's
# kernel, in a fresh process (docs/benchmarks.md, "First queries of every
# kind").  Closest or any hit of fewer than PACKET_MIN rays (no packets):
QUERY_S = {"none": 4, "bvol": 4, "bvh": 4, "grid": 5, "kdtree": 5}
# The BVH's larger kernels: closest or any hit of PACKET_MIN rays or more
# (packets), counting and listing every hit (their own tree and loops).
BVH_QUERY_S = {"packets": 6, "count": 7, "list": 5}
# Counting or listing on another structure adds COUNT_S to QUERY_S; the
# point queries walk a BVH, built first where the structure is another.
COUNT_S = 1
POINTS_S = {"bvh": 4}
POINTS_OTHER_S = 5

_lock = threading.Lock()
_state = {"shown": False, "quiet": False, "listening": False, "fallback": None}
_active = threading.local()


def set_quiet(quiet=True):
    """No notice in this process (the command's -q)."""
    _state["quiet"] = bool(quiet)


def _quiet():
    return _state["quiet"] or os.environ.get("RAYTRACE_QUIET", "") not in ("", "0")


def _listen(load=True):
    """Register for Numba's compile events; ``load=False``: only if Numba is
    imported already (a bad file name is reported without importing it)."""
    if _state["listening"] or not (load or "numba" in sys.modules):
        return
    import numba.core.event as event

    class Notice(event.Listener):
        def on_start(self, ev):
            _compile_started(ev.data.get("dispatcher") if isinstance(ev.data, dict) else None)

        def on_end(self, ev):
            pass

    with _lock:
        if not _state["listening"]:
            event.register("numba:compile", Notice())
            _state["listening"] = True


def _label(what, seconds):
    if callable(seconds):        # worked out only when a compile starts (expecting_render's)
        seconds = seconds()
    about = f", about {seconds:.0f} s" if seconds else ""
    return f"compiling kernels for {what} (first run only{about})"


def _compile_started(dispatcher):
    if _state["shown"] or _quiet():
        return
    line = getattr(_active, "line", None) or _state["fallback"]
    if line is None:
        name = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
        if not name.startswith("raytrace."):
            return
        line = _label(name.rsplit(".", 1)[-1], None)
    with _lock:
        if _state["shown"]:
            return
        _state["shown"] = True
    try:
        if callable(line):
            line = line()
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):      # a closed stderr is no reason to fail a render
        pass


@contextlib.contextmanager
def expecting(what, seconds=None, load=True):
    """Inside, a compile that starts is announced as ``what`` (``seconds``: its
    estimate, or a function of none giving it then).  An enclosing
    ``expecting`` (the command's) keeps its own words.  ``load``: as for
    _listen."""
    _listen(load)
    if getattr(_active, "line", None) is not None:
        yield
        return
    _active.line = functools.partial(_label, what, seconds)
    try:
        yield
    finally:
        _active.line = None


def query_seconds(accel, query, n_rays):
    """The estimate of a RayScene's first ``query`` (cast/ahead.py's
    names) of ``n_rays`` rays on structure ``accel``."""
    if query == "points":
        return POINTS_S.get(accel, POINTS_OTHER_S)
    base = QUERY_S.get(accel)
    if accel != "bvh":
        return base + COUNT_S if base and query in ("count", "list") else base
    if query in ("count", "list"):
        return BVH_QUERY_S[query]
    from raytrace.kernels.cast import PACKET_MIN
    return BVH_QUERY_S["packets"] if n_rays >= PACKET_MIN else base


def expect(what, seconds=None):
    """Announce compiles outside any ``expecting`` block as ``what`` from now on
    (a RayScene: its structure is built and its kernels run in later calls)."""
    _listen()
    _state["fallback"] = _label(what, seconds)


def first_run():
    """Whether no render kernel is in the cache at all (a compile is
    certain) and the notice is neither shown yet nor silenced."""
    if _state["shown"] or _quiet():
        return False
    from raytrace.kernels.cachedir import any_render_kernel_cached
    return not any_render_kernel_cached()


def announce_if_cold(what, seconds):
    """Say it now, before Numba is even imported, on a first run."""
    if first_run():
        _state["shown"] = True
        try:
            sys.stderr.write(_label(what, seconds) + "\n")
            sys.stderr.flush()
        except (OSError, ValueError):
            pass


def render_estimate(accel, bounces, textures, integrator="whitted"):
    """Seconds a cold render compile takes, about."""
    if integrator == "path":      # its two entries, mirrors and glass included
        from raytrace.kernels.pathtrace import run_path_shade
        if has_cache_entries(run_path_shade):
            return VARIANT_S
        return PATH_S + TEXTURES_S * bool(textures)
    from raytrace.kernels.wavefront import run_stage
    if has_cache_entries(run_stage):
        return VARIANT_S
    base = RENDER_S.get(str(accel).split(":")[0], 8)
    return base + BOUNCES_S * bool(bounces) + TEXTURES_S * bool(textures)


def command_estimate(accel, integrator, mesh_bytes=0):
    """The command's first-run estimate, from its options alone (``mesh_bytes``:
    the size of a mesh file, whose kernels compile as it loads if it is not
    small)."""
    base = PATH_S if integrator == "path" else RENDER_S.get(accel, 8) + 1
    return base + MESH_S * (mesh_bytes > SMALL_MESH_BYTES)


def render_what(scene_name, accel, shadows, integrator):
    path = ", path tracer" if integrator == "path" else ""
    return f"{scene_name}: {accel}, {shadows} shadows{path}"


def scene_estimate(scene, accel, integrator="whitted"):
    """render_estimate for a Scene, read from its description (before flattening)."""
    from raytrace.scene.model import Mesh
    objects = getattr(scene, "objects", None) or []
    bounces = any(o.material.bounces() for o in objects if hasattr(o, "material"))
    textures = any(isinstance(o, Mesh) and (o.colors is not None or o.uv is not None)
                   for o in objects)
    return render_estimate(accel, bounces, textures, integrator)


def expecting_render(scene, opts, integrator="whitted"):
    """The block that flattens, builds and renders ``scene`` with ``opts``
    (and its ``integrator``).  The estimate reads the render kernel's cache
    index (has_cache_entries), which a warm render's load reads anyway: only
    when a compile starts."""
    return expecting(render_what(getattr(scene, "name", "the scene"), opts.accel, opts.shadows,
                                 integrator),
                     lambda: scene_estimate(scene, opts.accel, integrator))
