"""After `raytrace warmup --all`, does every command and API call start warm?

    python bench/warm_all.py [--cache DIR] [--skip-warmup] [--repeat N]

In an empty Numba cache (a new temporary directory, or --cache), runs
`raytrace warmup --all`, then each command below in a fresh process and
reads its "Compile/load time" (time.compile_s of --json), and each API call
as the first call of a fresh process (NumPy, Numba and the module imported
before the clock starts): its first call's time and a second call's, whose
difference is the compile or cache load.  Issue 46's figure: every one
under 0.5 s.  Each is run --repeat times, in rounds (every row once, then
again), and its min and median are shown, with the load average.

Beside them, "Numba's own first call": a one-line function in its own
cache, first called in a fresh process set up as the API rows are: what a
cache load costs where Numba refreshes its target context first (every
compile registry imported and installed).  raytrace's cache loads without
that refresh (kernels/kernel_cache.py), so its rows can be below it.  Bytecode is cached for the children
(PYTHONDONTWRITEBYTECODE dropped), as an installed package has it: without,
each first call compiles raytrace's modules from source too.  Markdown on
stdout.
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

LIMIT_S = 0.5
TOYS = Path(__file__).resolve().parent.parent / "assets" / "toys.obj"  # commands run in a temp dir
COMMANDS = [
    *[["teapot", "--accel", a] for a in ("none", "bvol", "bvh", "grid", "kdtree")],
    *[["teapot", "--accel", a, "--shadows", "soft"] for a in ("bvh", "grid", "kdtree")],
    ["teapot", "--shadows", "none"],
    ["teapot", "--bvh-build", "median"],
    ["teapot", "--bvh-build", "lbvh"],
    ["teapot", "--spp", "4", "--texture-filter", "none"],
    ["teapot", "--aov", "depth,normal,primid,cost"],
    ["teapot", "--heatmap", "HEAT"],
    ["teapot", "--detail", "128"],
    ["whitted"], ["glass_teapot"], ["textured"], [str(TOYS), "--view", "front"],
    ["whitted", "--shadows", "soft"], ["textured", "--accel", "grid"],
    ["teapot", "--turntable", "2", "-o", "spin.gif"],
    ["cornell", "--spp", "1"], ["teapot", "--integrator", "path", "--accel", "grid"],
    ["textured", "--integrator", "path", "--spp", "1"],
]

# name: (setup, call); each in a process of its own.  mesh: a closed
# icosphere (320 triangles); rays(n, dtype): n rays from outside towards it.
API_SETUP = """
import time, numpy as np, numba, trimesh, raytrace
import raytrace.cast.rayscene
m = trimesh.creation.icosphere(subdivisions=2)
mesh = (np.asarray(m.vertices), np.asarray(m.faces))
def rays(n, dtype=np.float64):
    rng = np.random.default_rng(1)
    o = np.tile([0.0, 0.0, 3.0], (n, 1)) + rng.uniform(-0.5, 0.5, (n, 3))
    d = -o + rng.uniform(-0.3, 0.3, (n, 3))
    return o.astype(dtype), d.astype(dtype)
"""
API = {
    "cast_rays, 8 rays": "raytrace.cast_rays(mesh, *rays(8))",
    "cast_rays, 100 rays": "raytrace.cast_rays(mesh, *rays(100))",
    "cast_rays, 8 float32 rays": "raytrace.cast_rays(mesh, *rays(8, np.float32))",
    "cast_rays, 100 float32 rays": "raytrace.cast_rays(mesh, *rays(100, np.float32))",
    **{f"cast_rays, 100 rays, accel={a}": f"raytrace.cast_rays(mesh, *rays(100), accel='{a}')"
       for a in ("none", "bvol", "grid", "kdtree")},
    "occluded, 8 rays": "raytrace.occluded(mesh, *rays(8), 1.0)",
    "occluded, 100 rays": "raytrace.occluded(mesh, *rays(100), 1.0)",
    "occluded, 100 float32 rays": "raytrace.occluded(mesh, *rays(100, np.float32), 1.0)",
    "RayScene.count_intersections, 8 rays": "raytrace.RayScene(mesh).count_intersections(*rays(8))",
    "RayScene.count_intersections, 100 rays":
        "raytrace.RayScene(mesh).count_intersections(*rays(100))",
    "RayScene.list_intersections, 8 rays": "raytrace.RayScene(mesh).list_intersections(*rays(8))",
    "RayScene.list_intersections, 100 rays":
        "raytrace.RayScene(mesh).list_intersections(*rays(100))",
    "RayScene.contains, 8 points": "raytrace.RayScene(mesh).contains(rays(8)[0] / 4)",
    "RayScene.contains, 100 points": "raytrace.RayScene(mesh).contains(rays(100)[0] / 4)",
    "RayScene.distance, 8 points": "raytrace.RayScene(mesh).distance(rays(8)[0])",
    "RayScene.distance, 100 points": "raytrace.RayScene(mesh).distance(rays(100)[0])",
    "RayScene.closest_points, 100 points": "raytrace.RayScene(mesh).closest_points(rays(100)[0])",
    "RayScene.signed_distance, 100 points": "raytrace.RayScene(mesh).signed_distance(rays(100)[0])",
    "cast_rays on a Scene (teapot), 100 rays":
        "raytrace.cast_rays(raytrace.load_scene('teapot'), *rays(100))",
    "render(teapot)": "raytrace.render('teapot', width=64, height=48)",
}


# Numba's own first call: a one-line kernel of a module of its own, in its own cache.
FLOOR_MODULE = """import numba
@numba.njit(cache=True)
def one(x):
    return x + 1
"""
FLOOR = "one_kernel.one(1)"


def first_and_second(call, env, path=None):
    code = ((f"import sys; sys.path.insert(0, {str(path)!r})\n" if path else "") + API_SETUP
            + ("import one_kernel\n" if path else "")
            + f"\nt0 = time.perf_counter(); {call}; t1 = time.perf_counter()\n"
            f"{call}; t2 = time.perf_counter()\nprint(t1 - t0, t2 - t1)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if p.returncode:
        return None, None, p.stderr.strip().splitlines()[-1]
    first, second = map(float, p.stdout.split()[-2:])
    return first, second, ""


def command(args, env, tmp):
    args = [str(Path(tmp) / "heat.png") if a == "HEAT" else a for a in args]
    out = [] if "-o" in args else ["-o", str(Path(tmp) / "x.png")]
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "raytrace", *args, *out, "--json", "-q"],
                       capture_output=True, text=True, env=env, cwd=tmp)
    wall = time.perf_counter() - t0
    if p.returncode:
        return None, wall, p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "failed"
    return json.loads(p.stdout)["time"]["compile_s"], wall, ""


def _load():
    return os.getloadavg()[0]


def _spread(values):
    """"min / median" of the values, or "-"."""
    if not values:
        return "-"
    return f"{min(values):.3f} / {statistics.median(values):.3f}"


def _over(values):
    return "over 0.5 s" if values and statistics.median(values) > LIMIT_S else ""


@click.command()
@click.option("--cache", type=click.Path(file_okay=False), default=None,
              help="Numba cache directory [default: a new empty one].")
@click.option("--skip-warmup", is_flag=True, help="The cache is warm already.")
@click.option("--repeat", type=click.IntRange(1, 20), default=3, show_default=True,
              help="Fresh processes for each row, run in rounds.")
def main(cache, skip_warmup, repeat):
    with tempfile.TemporaryDirectory(prefix="warm-all-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache or str(Path(tmp) / "cache"),
                   RAYTRACE_QUIET="1")
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        floor_dir = Path(tmp) / "floor"
        floor_dir.mkdir()
        (floor_dir / "one_kernel.py").write_text(FLOOR_MODULE)
        floor_env = dict(env, NUMBA_CACHE_DIR=str(floor_dir / "cache"))
        first_and_second(FLOOR, floor_env, floor_dir)              # its cache, filled
        print(f"Load average {_load():.1f} at the start; {repeat} fresh processes a row.\n")
        if not skip_warmup:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "raytrace", "warmup", "--all", "-q"], env=env,
                           check=True)
            print(f"`raytrace warmup --all`: {time.perf_counter() - t0:.0f} s\n")
        compile_s, walls, errors = ({tuple(a): [] for a in COMMANDS} for _ in range(3))
        for _ in range(repeat):
            for args in COMMANDS:
                c, wall, err = command(args, env, tmp)
                if err:
                    errors[tuple(args)] = err
                else:
                    compile_s[tuple(args)].append(c)
                    walls[tuple(args)].append(wall)
        print("| command | Compile/load s, min / median | whole command s, median | |")
        print("|---|---:|---:|---|")
        for args in COMMANDS:
            c, w = compile_s[tuple(args)], walls[tuple(args)]
            shown = " ".join("heat.png" if a == "HEAT" else "assets/toys.obj" if a == str(TOYS)
                             else a for a in args)
            wall = f"{statistics.median(w):.2f}" if w else "-"
            print(f"| `raytrace {shown}` | {_spread(c)} | {wall} | "
                  f"{errors[tuple(args)] or _over(c)} |", flush=True)
        rows = {"Numba's own first call (one cached one-line kernel)": (FLOOR, floor_env, floor_dir),
                **{name: (call, env, None) for name, call in API.items()}}
        extra, seconds, failed = ({name: [] for name in rows} for _ in range(3))
        for _ in range(repeat):
            for name, (call, e, path) in rows.items():
                first, second, err = first_and_second(call, e, path)
                if first is None:
                    failed[name] = err
                else:
                    extra[name].append(first - second)
                    seconds[name].append(second)
        print("\n| API call, first in its process | first - second s, min / median | "
              "second s, median | |")
        print("|---|---:|---:|---|")
        for name in rows:
            x = extra[name]
            second = f"{statistics.median(seconds[name]):.3f}" if seconds[name] else "-"
            print(f"| {name} | {_spread(x)} | {second} | {failed[name] or _over(x)} |")
        api = [statistics.median(extra[n]) for n in API if extra[n]]
        cmds = [statistics.median(v) for v in compile_s.values() if v]
        floor = extra[next(iter(rows))]
        print(f"\nIssue 46's figure: API first calls, median over {repeat} processes: "
              f"{sum(v > LIMIT_S for v in api)} of {len(api)} over {LIMIT_S} s "
              f"(range {min(api, default=0):.3f}-{max(api, default=0):.3f} s; Numba's own first "
              f"call {_spread(floor)} s of it); commands' compile/load: "
              f"{sum(v > LIMIT_S for v in cmds)} of {len(cmds)} over {LIMIT_S} s "
              f"(range {min(cmds, default=0):.3f}-{max(cmds, default=0):.3f} s); load average "
              f"{_load():.1f} at the end.")


if __name__ == "__main__":
    main()
