"""Kernels compiled in a second process while this one does other work
(loads a scene, compiles a structure's builder and builds): on two or more
cores the two compiles overlap, and the caller waits for the longer of
them instead of their sum.  Numba compiles one function at a time in a
process, so a second process is the only way to use a second core.

``launch(key, module, args)`` runs ``python -m module args`` with a kernel
cache of its own; ``wait(key)`` waits for it and copies what it compiled
(each index after its data, under kernel_cache's index lock) into this
process's cache, from where the kernels then load.  Whatever becomes of the second
process, the caller goes on: without its entries, it compiles them itself.
Only where it can pay: more than one core, a kernel cache to share, and
``RAYTRACE_COMPILE_AHEAD`` not ``0``.  Once per key a process.  Users:
renderer/ahead.py (a first render's shading stages) and cast/ahead.py (a
first ray query's kernel).
"""
import atexit
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# key -> {"process": Popen, or False once it is done, "cache": its directory}
_runs = {}


def worthwhile(key):
    """Whether a second process for ``key`` can pay here and has not been
    started in this process."""
    if key in _runs or (os.cpu_count() or 1) < 2 or os.environ.get("RAYTRACE_COMPILE_AHEAD",
                                                                     "") == "0":
        return False
    from raytrace.kernels.jitconfig import CACHING
    return CACHING


def finish():
    """End a second process whose kernels are compiled, at once: Numba
    wrote each to the cache as it was compiled, and Python's teardown of
    the compiled modules (0.37-0.39 s after a first render's ray kernels)
    lay on a first run's critical path (docs/benchmarks.md, "A process
    ends at once")."""
    os._exit(0)


def launch(key, module, args):
    """Start ``python -m module *args`` compiling into a cache of its own
    (the caller checked ``worthwhile``), which starts as a copy of this
    process's (_seed)."""
    import numba
    ours = Path(numba.config.CACHE_DIR)
    cache = None
    try:
        cache = _cache_beside(ours)
        _seed(Path(cache) / ours.name, ours)
        process = subprocess.Popen([sys.executable, "-m", module, *map(str, args)],
                                   stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL, **child_setting(cache))
    except OSError:
        if cache:
            shutil.rmtree(cache, ignore_errors=True)
        return
    _runs[key] = {"process": process, "cache": cache}
    atexit.register(stop, key)


# A second process's cache folder left by a process killed outright (stop
# never ran) is removed by a later launch once it is this old.
_STALE_S = 24 * 3600


def _cache_beside(ours):
    """A new folder for the second process's cache: beside this process's
    cache ``ours``, so on its file system (_seed links), or where the
    system keeps temporary files.  Such folders older than _STALE_S go."""
    now = time.time()
    for old in ours.parent.glob("raytrace-ahead-*"):
        try:
            if now - old.stat().st_mtime > _STALE_S:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            pass
    try:
        return tempfile.mkdtemp(prefix="raytrace-ahead-", dir=ours.parent)
    except OSError:
        return tempfile.mkdtemp(prefix="raytrace-ahead-")


def _seed(theirs, ours):
    """Give the second process's cache ``theirs`` this process's entries,
    as hard links (instant; both caches replace a file by a rename, never
    write into one, so neither changes the other's): what is cached here
    (the teapot's shading helpers, say, before a first path-traced render)
    loads there instead of compiling again.  Where a link cannot be made
    (another file system, no links), it starts empty, as before: a path
    tracer's shading entry after the teapot compiled in 6.7 s so, against
    4.8 s in one process (docs/benchmarks.md, "A second process's cache")."""
    try:
        for path in ours.glob("*/*.nb[ic]"):
            target = theirs / path.relative_to(ours)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.link(path, target)
    except OSError:
        shutil.rmtree(theirs, ignore_errors=True)


def child_setting(cache):
    """The second process's environment and working directory: its own
    cache, and this process's raytrace, whatever the working directory
    holds.  ``python -m`` imports first from the working directory, and
    the README's first run is in a clone, so the second process compiled
    the clone's raytrace while this one ran the installed copy.  Numba's
    cache keys a kernel by its source file, so none of its kernels was
    found, and the first render compiled all of them alone (26 s, not 13)."""
    root = str(Path(__file__).parents[2])      # the folder holding raytrace/, as imported
    path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)
    env = dict(os.environ, RAYTRACE_QUIET="1", NUMBA_CACHE_DIR=cache, PYTHONPATH=path)
    return {"env": env, "cwd": cache}


def pending(key):
    """Whether ``key``'s second process was started and not yet waited for."""
    run = _runs.get(key)
    return bool(run and run["process"])


def wait(key):
    """Wait for ``key``'s second process, if one was started (once), and
    adopt what it compiled."""
    run = _runs.get(key)
    if not run or not run["process"]:
        return
    try:
        if run["process"].wait() == 0:
            _adopt(Path(run["cache"]))
    except OSError:
        pass                             # not adopted: the caller compiles them
    finally:
        stop(key)


def _adopt(cache):
    """Copy the second process's cache entries into this process's cache:
    the kernel, and the functions it calls, which the next kernel of
    another kind links in instead of compiling.  A function's index and
    data files where its index is not there yet, else its entries the
    index lacks (kernel_cache.merge_index: a second structure's ray
    kernels, where the first's are cached).  Data files first, then the
    index naming them, each by an atomic rename.  This process compiles
    nothing meanwhile, and an entry it has is left as it is."""
    import numba

    from raytrace.kernels.kernel_cache import index_lock, merge_index
    ours = Path(numba.config.CACHE_DIR)
    theirs = cache / ours.name
    for index in theirs.glob("*/*.nbi"):
        target = ours / index.parent.relative_to(theirs)
        if _same_file(index, target / index.name):    # seeded (_seed), and not saved again
            continue
        target.mkdir(parents=True, exist_ok=True)
        # Under the lock other processes save entries under: one saving this
        # function meanwhile would otherwise lose its entry to the copy.
        with index_lock(target / index.name):
            if (target / index.name).exists():
                merge_index(index, target / index.name)
                continue
            stem = index.name[:-len(".nbi")]
            for path in [*index.parent.glob(f"{stem}.*.nbc"), index]:
                tmp = target / f".{path.name}.tmp"
                shutil.copyfile(path, tmp)
                os.replace(tmp, target / path.name)


def _same_file(a, b):
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def stop(key):
    """Stop ``key``'s second process, if it runs, and remove its cache:
    once it is adopted, or when the caller no longer needs it (a failed
    build, the process's exit)."""
    run = _runs.get(key)
    if not run or not run["process"]:
        return
    process = run["process"]
    if process.poll() is None:
        process.kill()
        process.wait()
    run["process"] = False               # started once: never again in this process
    shutil.rmtree(run["cache"], ignore_errors=True)
