"""This checkout against an earlier commit, measured in one run: bench.py's
workshop and peer sections, run alternately in subprocesses for each tree
(A B A B ...), so that load from other processes falls on both alike.

    python bench/versus.py REV [--rounds 2] [--quick] [--sections workshop,peer]

REV's tree is checked out into a temporary git worktree and run with its own
code (PYTHONPATH); REV may also be the path of a checkout, whose compiled
kernels Numba's cache may already hold (a new worktree's files are new to
the cache, and the old six-minute kernel compiles again).  Compile time is excluded
by bench.py itself.  Reported: each cell's median over all its runs in every
round, for both trees, and the speed ratio (above 1: this checkout is
faster).  Markdown on stdout.
"""
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parent.parent


def run_tree(tree, sections, quick, out):
    cmd = [sys.executable, str(tree / "bench" / "bench.py"), "--sections", sections,
           "--json", str(out), "--plot", str(out.with_suffix(".png"))]
    if quick:
        cmd.append("--quick")
    env = dict(__import__("os").environ, PYTHONPATH=str(tree))
    subprocess.run(cmd, cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL)
    return json.loads(out.read_text())


def cells(report):
    """{cell name: ([seconds...], 'lower' or 'higher' is better)}"""
    out = {}
    for row in report.get("workshop", {}).get("rows", []):
        for accel, c in row["cells"].items():
            out[f"workshop | {row['label']} | {accel}"] = c["times_s"]
    for case in report.get("peer", {}).get("cases", []):
        for kind, modes in case["ours"].items():
            for mode, m in modes.items():
                out[f"peer {case['triangles']:,} tris | {kind} | ours {mode}"] = m["times_s"]
    return out


@click.command()
@click.argument("rev")
@click.option("--rounds", default=2, show_default=True)
@click.option("--quick", is_flag=True)
@click.option("--sections", default="workshop,peer", show_default=True)
def main(rev, rounds, quick, sections):
    given = Path(rev)
    sha = subprocess.run(["git", "rev-parse", "--short", "HEAD" if given.is_dir() else rev],
                         cwd=given if given.is_dir() else ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="raytrace-versus-") as tmp:
        tmp = Path(tmp)
        old = given.resolve() if given.is_dir() else tmp / "old"
        if not given.is_dir():
            subprocess.run(["git", "worktree", "add", "--detach", str(old), rev], cwd=ROOT,
                           check=True, capture_output=True)
        try:
            times = {"old": {}, "new": {}}
            for r in range(rounds):
                for side, tree in (("old", old), ("new", ROOT)):
                    print(f"versus: round {r + 1}/{rounds}, {side}", file=sys.stderr, flush=True)
                    rep = run_tree(tree, sections, quick, tmp / f"{side}{r}.json")
                    for k, ts in cells(rep).items():
                        times[side].setdefault(k, []).extend(ts)
        finally:
            if not given.is_dir():
                subprocess.run(["git", "worktree", "remove", "--force", str(old)], cwd=ROOT,
                               capture_output=True)
    print(f"### {head} (new) against {sha} (old), {rounds} alternating rounds"
          f"{' (quick)' if quick else ''}\n")
    print("| Cell | Old median s | New median s | New speed / old |")
    print("| --- | ---: | ---: | ---: |")
    ratios = []
    for k in times["new"]:
        if k not in times["old"]:
            continue
        o, n = statistics.median(times["old"][k]), statistics.median(times["new"][k])
        ratios.append(o / n)
        print(f"| {k} | {o:.4g} | {n:.4g} | {o / n:.3f} |")
    if ratios:
        print(f"\nGeometric mean of the speed ratios: "
              f"{statistics.geometric_mean(ratios):.3f} over {len(ratios)} cells.")


if __name__ == "__main__":
    main()
