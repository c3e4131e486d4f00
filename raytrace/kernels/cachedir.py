"""Where the compiled kernels are cached, worked out without importing
Numba (0.5-1 s), so the command can tell a first run at once."""
import functools
import hashlib
import os
from pathlib import Path


@functools.cache
def _sources_digest():
    """A hash of every module that compiles: the kernel floor and the
    structures, and any other module that compiles (the teapot's and big
    meshes' kernels in raytrace/scene).  Once a process: the command asks
    before Numba loads (firstrun.py) and jitconfig.py asks again."""
    package = Path(__file__).parent.parent
    sources = sorted({*package.glob("kernels/**/*.py"), *package.glob("accel/**/*.py"),
                      *(p for p in package.glob("**/*.py") if "from numba" in p.read_text())})
    digest = hashlib.sha1()
    for path in sources:
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest


def cache_dir(numba_version):
    """The cache directory, named by a hash of every module that compiles
    and the Numba version (jitconfig.py says why)."""
    digest = _sources_digest().copy()
    digest.update(numba_version.encode())
    root = os.environ.get("NUMBA_CACHE_DIR")
    if not root:
        root = os.environ.get("XDG_CACHE_HOME")
        if not root:
            try:
                root = Path.home() / ".cache"
            except (RuntimeError, KeyError):    # no home directory to be found
                root = Path("/nonexistent")
        root = Path(root) / "raytrace"
    return Path(root) / f"numba-{digest.hexdigest()[:16]}"


@functools.cache
def _numba_version():
    """Numba's version from its metadata, once a process (about 1.4 ms a
    read: three a render() call asked for it)."""
    from importlib.metadata import version
    return version("numba")


def kernel_cached(*index_globs, folder="*"):
    """Whether any version of a kernel is in the cache: an index file
    matching one of ``index_globs`` (file names, as Numba names a
    function's index) in a folder matching ``folder`` (Numba's, one a
    source folder: "kdtree_<hash>").  If not, this is a first run and a
    compile is certain."""
    from importlib.metadata import PackageNotFoundError
    try:
        where = cache_dir(_numba_version())
    except (PackageNotFoundError, OSError):
        return True                  # unknown: leave it to Numba's compile event
    key = (where, folder, index_globs)
    if key not in _FOUND:
        if not any(any(where.glob(f"{folder}/{name}")) for name in index_globs):
            return False
        # Found once, taken as there for the rest of the process: a glob
        # costs about 0.5 ms, several a render() call.
        _FOUND.add(key)
    return True


_FOUND = set()


def has_cache_entries(dispatcher):
    """Whether Numba's cache holds any compiled version of ``dispatcher`` for
    the current sources (its index: the caller has Numba loaded already).
    For the first-run notice, a compile is then a new variant of it, not the
    whole kernel set; for kernels/uncompiled.py, loading it beats running
    it as Python."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:      # Numba's private layout moved, or no cache: assume a cold one
        return False


def render_kernel_cached():
    """Whether any version of the render kernels (the shading stages, or
    the mirror-and-glass kernels) is in the cache."""
    return kernel_cached("wavefront.run_stage-*.nbi", "bounces.run_bounce_stage-*.nbi",
                         "bounces.run_bounce_shade-*.nbi")


def traversal_cached(module):
    """Whether any of structure ``module``'s traversal (its folder's
    traverse.py, raytrace/accel/<module>/) is in the cache.  If not, its
    ray kernels will compile (they may be missing even if it is there: a
    ray query compiled it for other types)."""
    return kernel_cached("traverse.*.nbi", folder=f"{module}_*")


def any_render_kernel_cached():
    """render_kernel_cached, or the path tracer's stage: whether anything
    has been rendered with this cache (a cache only path-traced renders
    filled is not a first run's)."""
    return render_kernel_cached() or kernel_cached("pathtrace.run_path_stage-*.nbi")
