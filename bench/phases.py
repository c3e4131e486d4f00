"""Where a big mesh's time and memory go, this checkout against another,
as a user runs it: `raytrace MESH --width 320 --height 240 --json`.

    python bench/phases.py MESH [--rev REV] [--rounds 3] [-- extra raytrace options]

MESH: a mesh file (bench/make_big.py writes the teapot at any detail) or a
built-in scene name.  Each run is a new process; REV's tree (a commit,
checked out into a temporary worktree, or the path of a checkout) and
this one alternate (A B B A ...), one warm-up each first, so the cache
holds both trees' kernels and drift hits both alike.  Reported: medians
of the whole command, the statistics' phases (time.load_s: reading and
framing the file; time.setup_s: flattening and the mode records;
time.build_s; time.compile_s; time.render_s) and the process's peak
memory; and whether the two images are identical.
Markdown on stdout.
"""
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT, run_cli  # noqa: E402

SIZE = ["--width", "320", "--height", "240"]


def run(tree, mesh, extra, out):
    """(wall s, stats, peak MB) of one command, with ``tree``'s raytrace (None: this one)."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    try:
        return run_cli([mesh, *SIZE, *extra, "-o", out], env=env, cwd=Path(out).parent)
    except RuntimeError as e:
        sys.exit(f"{e} ({tree or 'this checkout'})")


@click.command(context_settings={"ignore_unknown_options": True})
@click.argument("mesh")
@click.option("--rev", default=None, help="Commit or checkout to compare with.")
@click.option("--rounds", default=3, show_default=True)
@click.argument("extra", nargs=-1, type=click.UNPROCESSED)
def main(mesh, rev, rounds, extra):
    mesh = str(Path(mesh).resolve()) if Path(mesh).exists() else mesh
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"this checkout": None}
        if rev is not None:
            tree = Path(rev)
            if not tree.is_dir():
                tree = Path(tmp) / "rev"
                subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach",
                                str(tree), rev], check=True)
            trees = {rev: tree, "this checkout": None}
        try:
            runs = {name: [] for name in trees}
            for tree in trees.values():                          # warm-up: compile or load
                run(tree, mesh, extra, str(Path(tmp) / "warm.png"))
            for r in range(rounds):
                order = list(trees.items()) if r % 2 == 0 else list(trees.items())[::-1]
                for k, (name, tree) in enumerate(order):
                    runs[name].append(run(tree, mesh, extra, str(Path(tmp) / f"{k}.png")))
                    print(f"{name}: {runs[name][-1][0]:.2f} s", file=sys.stderr)
            images = {name: (Path(tmp) / f"{k}.png").read_bytes()
                      for k, (name, _) in enumerate(order)}
        finally:
            if rev is not None and not Path(rev).is_dir():
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                str(Path(tmp) / "rev")], check=False)
    stats = runs["this checkout"][-1][1]
    print(f"### `raytrace {Path(mesh).name} {' '.join(SIZE + list(extra))}`: "
          f"{stats['triangles']:,} triangles, median of {rounds}\n")
    print("| tree | whole command (s) | load (s) | flatten (s) | build (s) | compile/load (s) "
          "| render (s) | peak memory (MB) | bytes per triangle |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, rs in runs.items():
        def med(f, rs=rs):
            return statistics.median(f(x) for x in rs)
        peak = med(lambda x: x[2])
        # load_s: a tree from before it was timed has none
        load = med(lambda x: x[1]['time'].get('load_s', float("nan")))
        print(f"| {name} | {med(lambda x: x[0]):.2f} | {load:.2f} "
              f"| {med(lambda x: x[1]['time']['setup_s']):.2f} "
              f"| {med(lambda x: x[1]['time']['build_s']):.2f} "
              f"| {med(lambda x: x[1]['time']['compile_s']):.2f} "
              f"| {med(lambda x: x[1]['time']['render_s']):.3f} | {peak:.0f} "
              f"| {peak * 2**20 / max(1, stats['triangles']):.0f} |")
    if len(images) == 2:
        a, b = images.values()
        print(f"\nImages identical: {a == b}")


if __name__ == "__main__":
    main()
