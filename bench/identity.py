"""This checkout's images and counters against an earlier commit's, byte
for byte: every structure, shadows, mirrors, glass and textures.

    python bench/identity.py REV [--width 160 --height 120] [--quick]

REV's tree is checked out into a temporary git worktree and run with its
own code (PYTHONPATH), each tree with a kernel cache of its own.  Each case
is one ``raytrace ... --json`` command per tree; its PNG must decode to the
same pixels and its counters and structure statistics must be equal.
Markdown on stdout; exit 1 if any case differs.
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import click
import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
CASES = [
    ["teapot", "--accel", "none"],
    ["teapot", "--accel", "bvol"],
    ["teapot", "--accel", "bvh"],
    ["teapot", "--accel", "grid"],
    ["teapot", "--accel", "kdtree"],
    ["teapot", "--shadows", "soft"],
    ["teapot", "--accel", "kdtree", "--shadows", "soft", "--spp", "4"],
    ["teapot", "--detail", "43"],
    ["teapot", "--detail", "43", "--shadows", "soft"],
    ["spheres"],
    ["assets/whitted.toml"],
    ["assets/glass_teapot.toml", "--accel", "grid"],
    ["assets/textured.toml"],
    ["assets/toys.toml"],
]
QUICK = [0, 2, 3, 5, 10, 12]


def run(tree, case, size, out, cache):
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache / "numba"),
               XDG_CACHE_HOME=str(cache))
    args = [a if not a.startswith("assets/") else str(tree / a) for a in case]
    p = subprocess.run([sys.executable, "-m", "raytrace", "render", *args, *size, "-o", str(out),
                        "--json"], env=env, capture_output=True, text=True, cwd=tree)
    if p.returncode:
        raise SystemExit(f"{tree}: raytrace {' '.join(case)} failed: {p.stderr.strip()[-400:]}")
    stats = json.loads(p.stdout)
    return np.asarray(Image.open(out)), stats


@click.command()
@click.argument("rev")
@click.option("--width", default=160)
@click.option("--height", default=120)
@click.option("--quick", is_flag=True, help="six cases, not all")
@click.option("--cache", type=click.Path(file_okay=False), default=None,
              help="keep each tree's kernel cache here (cache-a, cache-b) for the next run")
def main(rev, width, height, quick, cache):
    size = ["--width", str(width), "--height", str(height)]
    cases = [CASES[k] for k in QUICK] if quick else CASES
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if Path(rev).is_dir():
            other = Path(rev).resolve()
        else:
            other = tmp / "rev"
            subprocess.run(["git", "worktree", "add", "--detach", str(other), rev], cwd=ROOT,
                           check=True, capture_output=True)
        try:
            bad = 0
            added = set()
            print(f"| case ({width}x{height}) | pixels | counters | structure |")
            print("| --- | --- | --- | --- |")
            for k, case in enumerate(cases):
                caches = Path(cache) if cache else tmp
                a_img, a = run(ROOT, case, size, tmp / f"a{k}.png", caches / "cache-a")
                b_img, b = run(other, case, size, tmp / f"b{k}.png", caches / "cache-b")
                # A counter one tree has and the other lacks (added since) is
                # listed below the table, not compared.
                shared = a["counters"].keys() & b["counters"].keys()
                added |= a["counters"].keys() ^ b["counters"].keys()
                same = [a_img.shape == b_img.shape and bool((a_img == b_img).all()),
                        all(a["counters"][k] == b["counters"][k] for k in shared),
                        a.get("structure") == b.get("structure")]
                bad += not all(same)
                print(f"| `{' '.join(case)}` | " + " | ".join("same" if s else "**differ**"
                                                            for s in same) + " |", flush=True)
            if added:
                print(f"\nCounters in one tree only (not compared): {', '.join(sorted(added))}")
        finally:
            if other.parent == tmp:
                subprocess.run(["git", "worktree", "remove", "--force", str(other)], cwd=ROOT,
                               capture_output=True)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
