"""Helpers shared by the benchmark scripts: timing protocol, image error,
Markdown tables, and a description of the machine a run was made on.

Timing protocol (one process, every script): one untimed warm-up render
per cell (Numba compile or cache load happens there and is reported apart
by the driver as time.compile_s anyway), then rounds over all cells in
turn, so that load from other processes on a shared machine hits every
cell alike; the figure reported is the median of a cell's runs.  A slow
cell gets fewer runs: floor(budget / first run), clamped to [1, max_runs].
"""
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from raytrace.accel.registry import STRUCTURES

ACCELS = tuple(STRUCTURES)
ROOT = Path(__file__).resolve().parent.parent


def render_time(result):
    """Seconds of the render kernel alone: no compile, no structure build."""
    return result.stats["time"]["render_s"]


def interleaved(cells, run_once, budget_s, max_runs, min_runs=1):
    """Time every cell in rounds; returns {cell: [seconds, ...]} and the
    first result of each cell.

    run_once(cell) -> (seconds, result).  Round 1 runs every cell once;
    its time fixes how many runs the cell gets in all (slow cells fewer).
    Later rounds visit, in the same order, only the cells still short.
    """
    times = {c: [] for c in cells}
    first = {}
    for c in cells:
        t, res = run_once(c)
        times[c].append(t)
        first[c] = res
    want = {c: max(min_runs, min(max_runs, int(budget_s // max(times[c][0], 1e-9))))
            for c in cells}
    while any(len(times[c]) < want[c] for c in cells):
        for c in cells:
            if len(times[c]) < want[c]:
                times[c].append(run_once(c)[0])
    return times, first


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def rmse(image, reference):
    """Root mean square difference over every pixel and channel (float64)."""
    d = np.asarray(image, np.float64) - np.asarray(reference, np.float64)
    return float(np.sqrt(np.mean(d * d)))


def psnr(err, peak=1.0):
    """Peak signal-to-noise ratio in dB for an RMSE, peak 1.0 (linear
    radiance of a fully lit white surface); inf for a zero error."""
    return math.inf if err == 0 else 20.0 * math.log10(peak / err)


def loglog_slope(xs, ys):
    """Least-squares slope of log(y) against log(x) (both positive)."""
    lx = np.log(np.asarray(xs, np.float64))
    ly = np.log(np.asarray(ys, np.float64))
    if len(lx) < 2 or np.ptp(lx) == 0:
        return float("nan")
    return float(np.polyfit(lx, ly, 1)[0])


def max_abs_diff(a, b):
    return float(np.max(np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))))


def markdown_table(header, rows, align=None):
    """A GitHub Markdown table; align is a string of 'l'/'r' per column
    (default: first column left, the rest right)."""
    align = align or "l" + "r" * (len(header) - 1)
    cells = [[str(h) for h in header]] + [[str(c) for c in r] for r in rows]
    width = [max(len(r[i]) for r in cells) for i in range(len(header))]

    def line(r):
        return "| " + " | ".join(c.ljust(w) if a == "l" else c.rjust(w)
                                 for c, w, a in zip(r, width, align)) + " |"
    rule = "| " + " | ".join(("-" * (w - 1) + ":") if a == "r" else "-" * w
                             for w, a in zip(width, align)) + " |"
    return "\n".join([line(cells[0]), rule] + [line(r) for r in cells[1:]])


def fmt_s(s):
    """Seconds with about three significant digits."""
    if s is None or (isinstance(s, float) and math.isnan(s)):
        return "n/a"
    if s >= 100:
        return f"{s:,.0f}"
    if s >= 10:
        return f"{s:.1f}"
    if s >= 1:
        return f"{s:.2f}"
    return f"{s:.3f}"


def fmt_g(x, digits=3):
    """A number with `digits` significant digits, thousands separated."""
    if x is None or (isinstance(x, float) and (math.isnan(x))):
        return "n/a"
    if x == 0 or not math.isfinite(x):
        return str(x)
    mag = int(math.floor(math.log10(abs(x))))
    dec = max(0, digits - 1 - mag)
    return f"{x:,.{dec}f}"


def _git(*args):
    try:
        out = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True,
                             timeout=10)
        return out.stdout.strip() if out.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        return None


def machine_info():
    """What a reader needs to weigh the numbers: CPU, cores, threads, load."""
    import numba

    import raytrace
    cpu = None
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                cpu = ln.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        load = os.getloadavg()
    except OSError:
        load = None
    return {
        "cpu": cpu or platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "load_avg_1_5_15": [round(x, 2) for x in load] if load else None,
        "python": platform.python_version(),
        "numba": numba.__version__,
        "numpy": np.__version__,
        "raytrace": str(Path(raytrace.__file__).resolve().parent),
        "git_commit": _git("rev-parse", "--short", "HEAD"),
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
    }


def machine_line(info):
    load = info["load_avg_1_5_15"]
    return (f"{info['cpu']}, {info['cores']} cores, {info['numba_threads']} Numba threads; "
            f"load average {load[0]:.1f} at start" if load else "")


# `raytrace ARGS` as the console script runs it, then this process's peak
# resident memory on stderr: VmHWM, its own (getrusage's ru_maxrss would
# add the parent's at the fork); "-" where /proc/self/status has none.  An
# exit handler: the command ends its process itself, after the handlers
# (raytrace/cli/command.py _end).
_CLI_WITH_PEAK = (
    "import atexit, runpy, sys\n"
    "def peak():\n"
    "    try:\n"
    "        hwm = [ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM:')]\n"
    "    except OSError:\n"
    "        hwm = []\n"
    "    sys.stderr.write(f\"peak {hwm[0] if hwm else '-'}\\n\")\n"
    "atexit.register(peak)\n"
    "sys.argv = ['raytrace'] + sys.argv[1:]\n"
    "runpy.run_module('raytrace', run_name='__main__')\n")


def run_cli(args, env=None, cwd=None):
    """Run `raytrace ARGS --json` in a fresh process: (wall s, its --json
    statistics, its peak resident memory in MB or None where unknown).

    The wall time is the whole command's, as a user waits: Python and
    Numba's imports, loading or making the scene, flattening, the build,
    the compile or cache load, the render and writing the image.  Raises
    RuntimeError with the command's stderr if it fails."""
    args = [str(a) for a in args] + ["--json"]
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", _CLI_WITH_PEAK, *args], capture_output=True,
                       text=True, env=env, cwd=cwd)
    wall = time.perf_counter() - t0
    err = p.stderr.strip().splitlines()
    peak = err.pop().split()[-1] if err and err[-1].startswith("peak ") else "-"
    if p.returncode != 0:
        msg = "\n".join(err).strip()
        raise RuntimeError(f"raytrace {' '.join(args)} failed: {msg}")
    return wall, json.loads(p.stdout), None if peak == "-" else int(peak) / 1024


def log(msg):
    """Progress goes to stderr, so stdout stays the Markdown report."""
    print(msg, file=sys.stderr, flush=True)


def save_figure(fig, path):
    """Write a matplotlib figure (its folder made if need be), close it and
    say so; returns the path as a string."""
    import matplotlib.pyplot as plt
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    log(f"wrote {path}")
    return str(path)
