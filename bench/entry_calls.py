"""What calling the renderer's kernels through their compiled entry points
(kernels/entry.py) saves over Numba's dispatcher, which types every
argument in Python on every call.

    python bench/entry_calls.py [--rounds 9] [--threads 2] [MESH_FILE ...]

One process: each scene is rendered with the dispatcher and with the
entry points in turn, round after round, and the medians of the render
times compared.  Small renders make the most calls per pixel: the Cornell
box path-traced at 64x64 (1 to 64 spp), the teapot at 160x120 and at its
640x480.  Mesh files given replace those: each at 120x90, Whitted and
path-traced at 5 spp, in this one process.
"""
import statistics
import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import render_time  # noqa: E402

CASES = [("cornell", dict(width=64, height=64), dict(spp=s)) for s in (1, 4, 16, 64)] + [
    ("teapot", dict(width=160, height=120), {}), ("teapot", {}, {})]


@click.command()
@click.option("--rounds", default=9, show_default=True)
@click.option("--threads", default=2, show_default=True)
@click.argument("files", nargs=-1, type=click.Path(exists=True, dir_okay=False))
def main(rounds, threads, files):
    from raytrace import load_scene, render
    from raytrace.kernels import entry
    through_entry = entry.Entry.__call__

    def through_dispatcher(self, *args):
        return self.kernel(*args)

    cases = CASES if not files else [
        (f, dict(width=120, height=90), opts) for f in files
        for opts in ({}, dict(integrator="path", spp=5))]
    scenes = {(name, str(size)): load_scene(name, **size) for name, size, _ in cases}
    modes = (("dispatcher", through_dispatcher), ("entry", through_entry))
    times = {}
    for r in range(rounds + 1):          # round 0 compiles or loads, untimed
        for mode, call in modes:
            entry.Entry.__call__ = call
            for k, (name, size, opts) in enumerate(cases):
                result = render(scenes[name, str(size)], seed=r, threads=threads, **opts)
                if r:
                    times.setdefault((mode, k), []).append(render_time(result))
    entry.Entry.__call__ = through_entry
    print("| scene | options | dispatcher ms | entry ms | speed-up |\n|---|---|---:|---:|---:|")
    for k, (name, size, opts) in enumerate(cases):
        a, b = (statistics.median(times[m, k]) for m, _ in modes)
        shown = f"{size.get('width', 640)}x{size.get('height', 480)} " + " ".join(
            f"{o} {v}" for o, v in opts.items())
        print(f"| {name} | {shown} | {a * 1e3:.1f} | {b * 1e3:.1f} | {a / b:.2f}x |")


if __name__ == "__main__":
    main()
