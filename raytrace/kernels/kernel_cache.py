"""The compiled-kernel cache, checked.  Numba trusts its cache files: a
truncated or garbage index fails to unpickle (a traceback), a directory in
a file's place raises IsADirectoryError, and data files swapped between
entries load one function's machine code as another's (a segfault).

Here each data file starts with a SHA-256 of its own name and contents,
and holds its entry's key, so a damaged, truncated or swapped file, or one
written for another entry, is found before its machine code is loaded; a
damaged entry (index or data) is removed and compiled again, with one
warning line per process.

Processes sharing the cache (the suite's workers, Dask workers, a second
process compiling ahead) save entries under a lock.  Numba reads a
function's index, adds its entry and writes the index back, unlocked: two
processes saving two entries of one function at once (every structure's
closest-hit kernel is one function) kept only the last one, and could give
both entries the same data file name, so that one key's index entry named
the other's machine code (a known Numba race: numba/numba#10128).  Here the
index is read and written, and the data written before the entry that
names it, inside an exclusive lock on a file beside the index.

Only raytrace's own cache directory (jitconfig) is treated so; other Numba
users' caches are left as Numba has them.
"""
import contextlib
import hashlib
import itertools
import os
import shutil
import warnings

from numba.core import caching

try:
    import fcntl
except ImportError:        # not POSIX: entries are saved unlocked, as Numba saves them
    fcntl = None


class KernelCacheWarning(UserWarning):
    """The cache was damaged or cannot be written; the run goes on (this
    floor sits below raytrace.errors, so its own warning class)."""


def warn(message):
    warnings.warn(message, KernelCacheWarning, stacklevel=3)

MAGIC = b"raytrace-kernel-cache-2\n"
_DIGEST = hashlib.sha256().digest_size
_warned = set()


def _warn_once(kind, message):
    if kind not in _warned:
        _warned.add(kind)
        warn(message)


def _remove(path):
    """Remove a damaged cache entry, whatever it is (a file, a directory)."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.unlink(path)
    except FileNotFoundError:
        pass


class _Damaged(Exception):
    pass


def _reason(exc):
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else (
        str(exc) or type(exc).__name__)


class CheckedCacheFile(caching.IndexDataCacheFile):
    """Numba's index and data files, with each data file's hash checked."""

    def _damaged(self, path, exc):
        _warn_once("damaged", f"kernel cache file {path} was damaged ({_reason(exc)}); "
                              "compiling it again")
        try:
            _remove(path)
        except OSError:
            pass

    def _load_index(self):
        try:
            overloads = super()._load_index()
            if not isinstance(overloads, dict) or not all(
                    isinstance(v, str) and os.path.basename(v) == v for v in overloads.values()):
                raise _Damaged("not an index")
            return overloads
        except (Exception, RecursionError) as exc:  # any unpickling failure: a damaged index
            self._damaged(self._index_path, exc)
            return {}

    def load(self, key):
        name = self._load_index().get(key)
        if name is None:
            return None
        try:
            return self._load_entry(name, key)
        except FileNotFoundError:
            return None
        except Exception as exc:
            self._damaged(self._data_path(name), exc)
            return None

    def _load_entry(self, name, key):
        with open(self._data_path(name), "rb") as f:
            data = f.read()
        head, digest, payload = data[:len(MAGIC)], data[len(MAGIC):len(MAGIC) + _DIGEST], \
            data[len(MAGIC) + _DIGEST:]
        if head != MAGIC or digest != _digest(name, payload):
            raise _Damaged("contents do not match their checksum")
        saved_key, entry = caching.pickle.loads(payload)
        if saved_key != key:          # compared as Numba compares index keys
            raise _Damaged("it holds another entry")
        return entry

    def _save_entry(self, key, data):
        """Numba's save, locked, the data file written before the index
        entry that names it (so a reader never finds an entry without its
        data)."""
        payload = self._dump((key, data))
        with index_lock(self._index_path):
            overloads = self._load_index()
            name = overloads.get(key)
            if name is None:
                taken = set(overloads.values())
                name = next(n for n in map(self._data_name, itertools.count(1)) if n not in taken)
            with self._open_for_write(self._data_path(name)) as f:
                f.write(MAGIC + _digest(name, payload) + payload)
            if overloads.get(key) != name:
                overloads[key] = name
                self._save_index(overloads)

    def save(self, key, data):
        try:
            self._save_entry(key, data)
        except IsADirectoryError as exc:     # a directory where a file goes: make room, once more
            self._damaged(exc.filename2 or exc.filename, exc)
            self._try_save(key, data)
        except OSError as exc:
            _warn_once("write", f"kernel cache {self._cache_path}: cannot write "
                                f"({_reason(exc)}); this run's kernels are not cached")

    def _try_save(self, key, data):
        try:
            self._save_entry(key, data)
        except OSError as exc:
            _warn_once("write", f"kernel cache {self._cache_path}: cannot write "
                                f"({_reason(exc)}); this run's kernels are not cached")


@contextlib.contextmanager
def index_lock(index_path):
    """An exclusive lock on a function's entries (a file beside its index)
    while the block runs: held for the milliseconds of a save; the system
    drops it if the process dies."""
    if fcntl is None:
        yield
        return
    with open(f"{index_path}.lock", "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX)
        except OSError:        # a file system without locks (some network ones): save as Numba does
            yield
            return
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def merge_index(theirs, ours):
    """Add to the function index ``ours`` (a path; its lock held) the
    entries of ``theirs`` (the same function's index in another process's
    cache) it lacks: each data file copied under a name free in ours,
    signed for that name, then the index naming them.  An index that does
    not read, or is of another Numba version or source stamp, adds
    nothing.  Data names are numbered per index, so a kernel compiled in
    both for different types (every structure's closest-hit kernel is one
    function) had its second entry dropped when only missing indexes were
    copied."""
    got = [_read_index(path) for path in (theirs, ours)]
    if None in got or got[0][:2] != got[1][:2]:
        return
    (version, stamp, their_entries), (_, _, entries) = got
    stem = ours.name[:-len(".nbi")]
    taken = set(entries.values())
    added = False
    for key, name in their_entries.items():
        if key in entries:
            continue
        try:
            with open(theirs.parent / name, "rb") as f:
                data = f.read()
        except OSError:
            continue
        payload = data[len(MAGIC) + _DIGEST:]
        if data[:len(MAGIC)] != MAGIC or data[len(MAGIC):len(MAGIC) + _DIGEST] != _digest(
                name, payload):
            continue
        new = next(n for n in (f"{stem}.{i}.nbc" for i in itertools.count(1)) if n not in taken)
        taken.add(new)
        _write_whole(ours.parent / new, MAGIC + _digest(new, payload) + payload)
        entries[key] = new
        added = True
    if added:
        _write_whole(ours, caching.pickle.dumps(version, protocol=-1) +
                     caching.dumps((stamp, entries)))


def _read_index(path):
    """(Numba version, source stamp, {key: data file name}) of an index
    file as Numba writes it, or None if it does not read."""
    try:
        with open(path, "rb") as f:
            version = caching.pickle.load(f)
            stamp, entries = caching.pickle.loads(f.read())
    except Exception:           # missing, damaged, or another Numba's format
        return None
    return (version, stamp, entries) if isinstance(entries, dict) else None


def _write_whole(path, data):
    """Write ``path`` by an atomic rename: a reader sees all of it or none."""
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def _digest(name, payload):
    return hashlib.sha256(name.encode() + b"\0" + payload).digest()


def install(cache_dir):
    """Check the cache files of every function cached under ``cache_dir``."""
    root = os.path.abspath(cache_dir)
    original = caching.Cache.__init__
    if getattr(original, "_raytrace_root", None) is not None:
        return

    def __init__(self, py_func):
        original(self, py_func)
        path = os.path.abspath(self._cache_path)
        if path == root or path.startswith(root + os.sep):
            self._cache_file.__class__ = CheckedCacheFile

    __init__._raytrace_root = root
    caching.Cache.__init__ = __init__
    # Numba checks a cache directory is writable by creating a file in it
    # for every cached function it meets (over a hundred at import): here
    # once a directory and process, then only that it is still there.
    writable = set()
    ensure = caching._CacheLocator.ensure_cache_path

    def ensure_cache_path(self):
        path = self.get_cache_path()
        if path in writable and os.path.isdir(path):
            return
        ensure(self)
        if path == root or path.startswith(root + os.sep):
            writable.add(path)

    caching._CacheLocator.ensure_cache_path = ensure_cache_path
    _load_without_refresh(root)


def _load_without_refresh(root):
    """Load a cached kernel without refreshing Numba's target context.
    Numba refreshes it before every cache load: it imports and installs
    every lowering and typing registry, 0.45 s of a warm command's 1.6 s
    CPU, for what only compiling uses.  Loading machine code needs the
    symbols it links against: Numba's C helpers and the math functions
    (added when the context is made), the runtime's (rtsys.initialize)
    and the hash secret's (added when numba.cpython.hashing is imported).
    A compile still refreshes the context first (Numba's compiler does)."""
    from numba.core.runtime import rtsys
    original = caching.Cache.load_overload
    if not all(hasattr(caching.Cache, n) for n in ("_load_overload",
                                                   "_guard_against_spurious_io_errors")):
        return       # another Numba's internals: its own loading, with the refresh

    def load_overload(self, sig, target_context):
        path = os.path.abspath(self._cache_path)
        if not (path == root or path.startswith(root + os.sep)):
            return original(self, sig, target_context)
        rtsys.initialize(target_context)
        import numba.cpython.hashing  # noqa: F401  (its symbols)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    caching.Cache.load_overload = load_overload
