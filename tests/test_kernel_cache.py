"""The kernel cache shared by processes (raytrace/kernels/kernel_cache.py):
entries saved at the same moment by several processes are all kept, each
under a data file of its own, and an entry's data loads only for its key."""
import multiprocessing

import pytest

from raytrace.kernels import kernel_cache

PROCESSES, ENTRIES = 4, 40


def _cache_file(path):
    return kernel_cache.CheckedCacheFile(str(path), "kernel-7.py311", "stamp")


def _save_many(path, writer, start):
    cache = _cache_file(path)
    start.wait()
    for i in range(ENTRIES):
        cache.save(("sig", writer, i), f"machine code {writer} {i}")


@pytest.mark.skipif(kernel_cache.fcntl is None, reason="saves are locked on POSIX only")
def test_entries_saved_at_once_by_several_processes_are_all_kept(tmp_path):
    # Each process adds its own keys to one function's index, as the
    # suite's workers or Dask workers compiling different structures do.
    ctx = multiprocessing.get_context("fork")
    start = ctx.Event()
    workers = [ctx.Process(target=_save_many, args=(tmp_path, w, start)) for w in range(PROCESSES)]
    for w in workers:
        w.start()
    start.set()
    for w in workers:
        w.join(60)
        assert w.exitcode == 0
    cache = _cache_file(tmp_path)
    index = cache._load_index()
    assert len(index) == PROCESSES * ENTRIES
    assert len(set(index.values())) == PROCESSES * ENTRIES        # a data file each
    for w in range(PROCESSES):
        for i in range(ENTRIES):
            assert cache.load(("sig", w, i)) == f"machine code {w} {i}"


def test_an_entrys_data_does_not_load_for_another_key(tmp_path, recwarn):
    cache = _cache_file(tmp_path)
    cache.save(("sig", "a"), "code of a")
    cache.save(("sig", "b"), "code of b")
    index = cache._load_index()
    # The index names a's data file for b, as the unlocked race could leave it.
    index[("sig", "b")] = index[("sig", "a")]
    cache._save_index(index)
    assert cache.load(("sig", "b")) is None                 # compiled again, not a's code run
    assert any("damaged" in str(w.message) for w in recwarn)


def test_a_file_system_without_locks_still_caches(tmp_path, monkeypatch, recwarn):
    import errno

    def no_locks(f, operation):
        raise OSError(errno.ENOLCK, "No locks available")
    if kernel_cache.fcntl is not None:
        monkeypatch.setattr(kernel_cache.fcntl, "flock", no_locks)
    cache = _cache_file(tmp_path)
    cache.save(("sig", "a"), "code of a")
    assert cache.load(("sig", "a")) == "code of a"
    assert not recwarn.list


LOADS = """
import sys
import numpy as np
import raytrace
s = raytrace.RayScene((np.eye(3), np.array([[0, 1, 2]])), accel="none")
hit = s.cast_rays([0.2, 0.2, 1.0], [0.0, 0.0, -1.0])["prim_id"][0]
print(hit, "numba.np.linalg" in sys.modules, "numba.typed.typeddict" in sys.modules)
"""


def test_a_warm_process_loads_kernels_without_numbas_compile_registries():
    """Numba refreshes its target context (imports and installs every
    lowering registry, ~0.45 s) before loading a cached kernel; raytrace's
    cache loads without it, as loading machine code needs only the
    runtime's and C helpers' symbols.  The second process finds the
    kernel cached (the first may compile it), answers the same, and
    never imports those registries."""
    import subprocess
    import sys
    runs = [subprocess.run([sys.executable, "-c", LOADS], capture_output=True, text=True,
                           timeout=300) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), [r.stderr for r in runs]
    assert runs[1].stdout.split() == ["0", "False", "False"], runs[1].stdout
