"""A turntable in this process against the same on a local Dask cluster.

    python bench/turntable.py [--frames 36] [--repeat 3] [--workers 2] [--json FILE]

Runs `raytrace teapot --turntable N --width 320 --height 240 -o F.gif`
(hard shadows) as a user would, alternating in-process and `--workers W`
runs so that the machine's drift hits both alike.  Frames/s is over the
frame phase (the statistics' time.wall_s: tasks, transfer, assembly and
the GIF, after the scene is built); the overhead is the cluster's frame
phase over the in-process one, minus one, with and without the workers'
one-time start-up inside it (sending the scene, whose first unpickling
imports raytrace and Numba on a worker, and loading the kernel).  On 2
cores no speedup is possible: the figure is what Dask costs.  What comes
before the frames (the cluster, imports, loading and building the scene)
is reported apart.
Markdown on stdout.
"""
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

ARGS = ["teapot", "--width", "320", "--height", "240", "--json", "-q"]


def run(frames, workers, out):
    cmd = [sys.executable, "-m", "raytrace", *ARGS, "--turntable", str(frames), "-o", out]
    if workers:
        cmd += ["--workers", str(workers)]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed: {p.stderr.strip()}")
    return wall, json.loads(p.stdout)


def warm_up():
    """Compile (or load) the kernels the runs use into the cache before
    timing anything: a tiny render of the same scene and options here (the
    record types, not the size, pick a kernel), not a process of its own."""
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    render(teapot(), accel="bvh", shadows="hard", width=16, height=12)


def measure(frames=36, repeat=3, workers=2):
    """{"here": figures, "dask": figures, "overhead": ratio - 1}; None
    without the distributed extra."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return None
    rows = {"here": [], "dask": []}
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "spin.gif")
        warm_up()
        for k in range(repeat):
            for where in (("here", "dask") if k % 2 == 0 else ("dask", "here")):
                wall, stats = run(frames, workers if where == "dask" else None, out)
                rows[where].append((wall, stats))
                print(f"turntable {where}: {wall:.2f} s", file=sys.stderr)

    def figures(runs):
        phase = statistics.median(s["time"]["wall_s"] for _, s in runs)
        # Without the one-time start-up inside the frame phase: sending the
        # scene (a worker's first unpickling imports raytrace and Numba) and
        # each worker's kernel load, which run in parallel (the longest).
        steady = statistics.median(
            s["time"]["wall_s"] - s["time"].get("scatter_s", 0.0)
            - max(w["compile_s"] for w in s["workers"].values()) for _, s in runs)
        whole = statistics.median(w for w, _ in runs)
        last = runs[-1][1]
        return {"frame_phase_s": phase, "fps": frames / phase, "steady_s": steady,
                "command_s": whole,
                "startup_s": whole - phase,
                "compile_per_worker_s": [w["compile_s"] for w in last["workers"].values()],
                "tiles_per_worker": [w["tiles"] for w in last["workers"].values()]}
    here, dask = figures(rows["here"]), figures(rows["dask"])
    return {"frames": frames, "repeat": repeat, "workers": workers, "here": here, "dask": dask,
            "overhead": dask["frame_phase_s"] / here["frame_phase_s"] - 1,
            "steady_overhead": dask["steady_s"] / here["steady_s"] - 1}


def markdown(res):
    if res is None:
        return ("### Turntable\n\nNot measured: needs the distributed extra "
                "(pip install 'raytrace[distributed]').")
    lines = [f"### Turntable: teapot, {res['frames']} frames at 320x240, hard shadows, "
             f"median of {res['repeat']}\n",
             "| where | frames/s | frame phase (s) | less workers' start-up (s) "
             "| whole command (s) | before the frames (s) | compile/load per worker (s) "
             "| tiles per worker |",
             "|---|---:|---:|---:|---:|---:|---|---|"]
    for name, f in (("this process", res["here"]), (f"--workers {res['workers']}", res["dask"])):
        lines.append(f"| {name} | {f['fps']:.1f} | {f['frame_phase_s']:.2f} | "
                     f"{f['steady_s']:.2f} | {f['command_s']:.2f} | {f['startup_s']:.2f} | "
                     f"{', '.join(f'{c:.2f}' for c in f['compile_per_worker_s'])} | "
                     f"{', '.join(map(str, f['tiles_per_worker']))} |")
    lines.append(f"\nDask's overhead on the frame phase: {res['overhead'] * 100:+.1f}%; without "
                 f"the workers' one-time start-up in it (the scene sent, the kernel loaded): "
                 f"{res['steady_overhead'] * 100:+.1f}% (aim: under 15%)")
    return "\n".join(lines)


@click.command()
@click.option("--frames", default=36, show_default=True)
@click.option("--repeat", default=3, show_default=True)
@click.option("--workers", default=2, show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
def main(frames, repeat, workers, json_path):
    res = measure(frames, repeat, workers)
    print(markdown(res))
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
