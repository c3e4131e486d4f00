"""A first render's shading stages compiled in a second process, while this
one loads the scene, compiles the structure's builder and ray kernels and
builds: on two or more cores the two compiles overlap, and the first render
waits for the longer of them instead of their sum.

Only on a first run (nothing of the shading stages in the kernel cache:
kernels/cachedir.render_kernel_cached, a glob) with a kernel cache to
share and more than one core (``RAYTRACE_COMPILE_AHEAD=0`` turns it
off).  The second process compiles the stages for
a tiny scene of the same kind (scene/kinds.py: the same types, so the same
kernels) into a cache of its own: two processes adding entries to one
Numba index at once can leave it naming another entry's file.  The render
waits for it (``wait``), copies what it compiled (each index after its
data) into its own cache and loads the stages from there.  Whatever becomes of the second
process, the render goes on: without its entries, it compiles the stages
itself.
"""
import atexit
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

_ahead = {"process": None, "cache": None}


def start(scene):
    """Start compiling the stages ``scene``'s render will use, if this is
    a first run on a machine with cores to spare."""
    if (_ahead["process"] is not None or (os.cpu_count() or 1) < 2
            or os.environ.get("RAYTRACE_COMPILE_AHEAD", "") == "0"):
        return
    from raytrace.kernels.cachedir import render_kernel_cached
    if render_kernel_cached():
        return
    from raytrace.kernels.jitconfig import CACHING
    if not CACHING:
        return
    from raytrace.scene.kinds import scene_kind
    textures, mirrors = scene_kind(scene)
    try:
        cache = tempfile.mkdtemp(prefix="raytrace-ahead-")
        env = dict(os.environ, RAYTRACE_QUIET="1", NUMBA_CACHE_DIR=cache)
        process = subprocess.Popen(
            [sys.executable, "-m", "raytrace.renderer.precompile", str(int(textures)),
             str(int(mirrors))], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, env=env)
    except OSError:
        return
    _ahead["process"], _ahead["cache"] = process, cache
    atexit.register(_stop, process)


def wait():
    """Wait for the second process, if one was started (once), and adopt
    what it compiled."""
    process = _ahead["process"]
    if not process:
        return
    try:
        if process.wait() == 0:
            _adopt(Path(_ahead["cache"]))
    except OSError:
        pass                             # not adopted: the render compiles them
    finally:
        _stop(process)


def _adopt(cache):
    """Copy the second process's cache entries into this process's cache,
    each entry (a function's index and data files) whose index is not there
    yet: the stages' entry, and the functions it calls, which the next
    render of another kind links in instead of compiling.  Data files
    first, then the index naming them, each by an atomic rename.  This
    process compiles nothing meanwhile, and an entry it has is left as it
    is."""
    import numba
    ours = Path(numba.config.CACHE_DIR)
    theirs = cache / ours.name
    for index in theirs.glob("*/*.nbi"):
        target = ours / index.parent.relative_to(theirs)
        if (target / index.name).exists():
            continue
        target.mkdir(parents=True, exist_ok=True)
        stem = index.name[:-len(".nbi")]
        for path in [*index.parent.glob(f"{stem}.*.nbc"), index]:
            tmp = target / f".{path.name}.tmp"
            shutil.copyfile(path, tmp)
            os.replace(tmp, target / path.name)


def _stop(process):
    if process.poll() is None:
        process.kill()
        process.wait()
    if _ahead["process"] is process:
        _ahead["process"] = False        # started once: never again in this process
        shutil.rmtree(_ahead["cache"], ignore_errors=True)
