"""The whole command, two trees alternated: `/usr/bin/time -v python -m
raytrace FILE --width 320 --height 240 --json`, a fresh process each, under
`nice -n 19`, the trees in the order A B, B A, ... so drift hits both alike.

    python bench/command_ab.py ROUNDS TREE_A:CACHE_A TREE_B:CACHE_B FILE...

TREE: a checkout's root (put first on PYTHONPATH, and each command runs
in a temporary folder: ``python -m`` imports first from the working
directory, so run from a checkout both trees ran its code); CACHE: its own Numba
cache (NUMBA_CACHE_DIR), warmed by a first run.  One JSON line a run: wall
and CPU (user + system) seconds, peak resident KB, the `--json` phases and
the first 10 hex digits of the PNG's SHA-1 (identical images, identical
digits).  Linux (GNU time).
"""
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time


def run(tree, cache, path, out):
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_CACHE_DIR=cache)
    t = time.perf_counter()
    r = subprocess.run(["nice", "-n", "19", "/usr/bin/time", "-v", sys.executable, "-m", "raytrace",
                        path, "--width", "320", "--height", "240", "-o", out, "--json"],
                       env=env, capture_output=True, text=True, check=True,
                       cwd=os.path.dirname(out))
    wall = time.perf_counter() - t

    def field(name):
        return float(re.search(name + r": ([\d.]+)", r.stderr).group(1))
    with open(out, "rb") as fh:
        png = hashlib.sha1(fh.read()).hexdigest()[:10]
    return dict(tree=tree, file=os.path.basename(path), wall=round(wall, 2),
                cpu=round(field(r"User time \(seconds\)") + field(r"System time \(seconds\)"), 2),
                peak_kb=int(field(r"Maximum resident set size \(kbytes\)")),
                **{k: round(v, 2) for k, v in json.loads(r.stdout)["time"].items()}, png=png)


def main(rounds, a, b, *files):
    sides = [tuple(s.split(":")) for s in (a, b)]
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(int(rounds)):
            for path in files:
                for tree, cache in (sides if k % 2 == 0 else sides[::-1]):
                    print(json.dumps(run(tree, cache, path, os.path.join(tmp, "o.png"))),
                          flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
