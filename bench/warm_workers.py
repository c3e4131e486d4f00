"""`--workers` with and without the workers' warm-up, paired: this checkout
against another tree (an earlier commit's files), turn by turn, each run a
fresh `raytrace teapot --turntable N --workers W` process.

    python bench/warm_workers.py OLD_TREE [--pairs 3] [--cold-pairs 2] [--frames 12]
                                          [--detail N]

Cold: each run gets an empty Numba cache of its own (NUMBA_CACHE_DIR), so
every process compiles; warm: one cache per tree, filled by an untimed run
first.  Reported per run: the whole command's wall time, the frame phase
(time.wall_s), and each worker's warm-up and first-task compile/load.
``--detail``: a bigger teapot, whose loading is long enough to overlap the
cluster's start (issue 46).  Markdown on stdout.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parent.parent


def run(tree, cache, frames, workers, out, detail=None):
    cmd = [sys.executable, "-m", "raytrace", "teapot", "--width", "320", "--height", "240",
           "--turntable", str(frames), "--workers", str(workers), "--json", "-q", "-o", out,
           *(["--detail", str(detail)] if detail else [])]
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=Path(out).parent)
    wall = time.perf_counter() - t0
    if p.returncode:
        sys.exit(f"{' '.join(cmd)} failed: {p.stderr.strip()}")
    s = json.loads(p.stdout)
    return {"whole_s": wall, "frame_phase_s": s["time"]["wall_s"],
            "warmup_s": [w.get("warmup_s") for w in s["workers"].values()],
            "compile_s": [w["compile_s"] for w in s["workers"].values()]}


@click.command()
@click.argument("old", type=click.Path(exists=True, file_okay=False))
@click.option("--pairs", default=3, show_default=True, help="Warm pairs.")
@click.option("--cold-pairs", default=2, show_default=True)
@click.option("--frames", default=12, show_default=True)
@click.option("--workers", default=2, show_default=True)
@click.option("--detail", type=int, default=None, help="The teapot's --detail [default: its own].")
def main(old, pairs, cold_pairs, frames, workers, detail):
    trees = {"old": Path(old).resolve(), "new": ROOT}
    rows = []
    with tempfile.TemporaryDirectory(prefix="warm-workers-") as tmp:
        tmp = Path(tmp)
        out = str(tmp / "spin.gif")
        for k in range(cold_pairs):
            for side in (("old", "new") if k % 2 == 0 else ("new", "old")):
                r = run(trees[side], tmp / f"cold-{side}-{k}", frames, workers, out, detail)
                rows.append(("cold", side, r))
                print(f"cold {side}: {r['whole_s']:.1f} s", file=sys.stderr, flush=True)
        for side in trees:
            run(trees[side], tmp / f"warm-{side}", 2, workers, out, detail)     # fill the cache
        for k in range(pairs):
            for side in (("old", "new") if k % 2 == 0 else ("new", "old")):
                r = run(trees[side], tmp / f"warm-{side}", frames, workers, out, detail)
                rows.append(("warm", side, r))
                print(f"warm {side}: {r['whole_s']:.1f} s", file=sys.stderr, flush=True)

    def fmt(xs):
        return ", ".join("-" if x is None else f"{x:.2f}" for x in xs)
    print(f"### teapot{f' --detail {detail}' if detail else ''}, {frames} frames at 320x240, "
          f"--workers {workers}: old {trees['old']} "
          f"against new {trees['new']}\n")
    print("| cache | tree | whole command s | frame phase s | warm-up per worker s "
          "| first-task compile/load per worker s |")
    print("|---|---|---:|---:|---|---|")
    for cache, side, r in rows:
        print(f"| {cache} | {side} | {r['whole_s']:.2f} | {r['frame_phase_s']:.2f} | "
              f"{fmt(r['warmup_s'])} | {fmt(r['compile_s'])} |")
    print()
    for cache in ("cold", "warm"):
        med = {side: statistics.median(r["whole_s"] for c, s, r in rows if c == cache and s == side)
               for side in trees if any(c == cache and s == side for c, s, _ in rows)}
        if len(med) == 2:
            print(f"{cache}: median whole command old {med['old']:.2f} s, new {med['new']:.2f} s "
                  f"(new - old {med['new'] - med['old']:+.2f} s)")


if __name__ == "__main__":
    main()
