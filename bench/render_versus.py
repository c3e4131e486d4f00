"""Warm render time of this checkout against another checkout, the teapot
at 640x480 with the BVH, alternating trees in fresh processes (each tree
with a kernel cache of its own, kept between runs).

    python bench/render_versus.py OTHER_CHECKOUT [--details 0,43] [--shadows hard,soft]
                                  [--rounds 3] [--renders 5] [--cache DIR]

Each process renders ``--renders`` times after one untimed render; the
table gives each tree's median render seconds over every round but the
first (which compiled).  Markdown on stdout.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parent.parent
ONE = """
import json, sys
import raytrace
from raytrace import render     # the public API: module paths differ between commits
detail, shadows, renders = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
scene = raytrace.load_scene("teapot", **({"detail": detail} if detail else {}))
times = []
for i in range(renders + 1):
    r = render(scene, accel="bvh", shadows=shadows, width=640, height=480, threads=2)
    if i:
        times.append(r.stats["time"]["render_s"])
print(json.dumps(times))
"""


def run(tree, cache, detail, shadows, renders):
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache / "numba"),
               XDG_CACHE_HOME=str(cache), RAYTRACE_QUIET="1")
    p = subprocess.run([sys.executable, "-c", ONE, str(detail), shadows, str(renders)],
                       env=env, cwd=tempfile.gettempdir(), capture_output=True, text=True,
                       check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


@click.command()
@click.argument("other", type=click.Path(exists=True, file_okay=False))
@click.option("--details", default="0,43", show_default=True)
@click.option("--shadows", default="hard,soft", show_default=True)
@click.option("--rounds", default=3, show_default=True)
@click.option("--renders", default=5, show_default=True)
@click.option("--cache", type=click.Path(file_okay=False), default=None,
              help="keep the trees' kernel caches here between runs")
def main(other, details, shadows, rounds, renders, cache):
    trees = {"other": Path(other).resolve(), "this": ROOT}
    caches = Path(cache) if cache else Path(tempfile.mkdtemp(prefix="raytrace-rv-"))
    print("| teapot | shadows | other ms | this ms | speed this/other |\n|---|---|---:|---:|---:|")
    for detail in (int(d) for d in details.split(",")):
        for mode in shadows.split(","):
            times = {name: [] for name in trees}
            for r in range(rounds):
                for name, tree in trees.items():
                    got = run(tree, caches / name, detail, mode, renders)
                    if r or rounds == 1:
                        times[name] += got
            old, new = (statistics.median(times[k]) * 1000 for k in ("other", "this"))
            print(f"| detail {detail or 'default'} | {mode} | {old:.1f} | {new:.1f} | {old / new:.2f} |",
                  flush=True)


if __name__ == "__main__":
    main()
