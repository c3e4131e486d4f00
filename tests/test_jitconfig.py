"""Where compiled kernels are cached: a directory named by a hash of the
kernel sources, under NUMBA_CACHE_DIR when it is set (raytrace/kernels/jitconfig.py)."""
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = "import raytrace.kernels.jit, numba; print(numba.config.CACHE_DIR)"


def cache_dir(env):
    p = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return Path(p.stdout.strip())


def test_cache_directory_is_named_by_the_sources_hash(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    default = cache_dir(dict(env, XDG_CACHE_HOME=str(tmp_path / "xdg")))
    assert default.parent == tmp_path / "xdg" / "raytrace"
    assert default.name.startswith("numba-") and len(default.name) == len("numba-") + 16
    # A user's NUMBA_CACHE_DIR says where, and the hash still separates
    # versions: an upgrade never loads (or fails to unpickle) older kernels.
    chosen = cache_dir(dict(env, NUMBA_CACHE_DIR=str(tmp_path / "mine")))
    assert chosen == tmp_path / "mine" / default.name


PROBES = """
import collections, tempfile
probes = collections.Counter()
real = tempfile.TemporaryFile
def counted(*args, **kwargs):
    probes[kwargs.get("dir")] += 1
    return real(*args, **kwargs)
tempfile.TemporaryFile = counted
import raytrace.kernels.waves, raytrace.accel.bvh
print(sum(probes.values()), len(probes))
"""


def test_the_cache_directory_is_checked_once_a_directory_not_once_a_kernel(tmp_path):
    """Numba checks a cache directory is writable with a file made in it,
    for each of the 100-odd cached functions the renderer imports;
    kernel_cache.install keeps one check a directory and process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    p = subprocess.run([sys.executable, "-c", PROBES], env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    probes, directories = map(int, p.stdout.split())
    assert 1 <= probes == directories <= 4, p.stdout
