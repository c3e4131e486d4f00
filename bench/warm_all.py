"""After `raytrace warmup --all`, does every command and API call start warm?

    python bench/warm_all.py [--cache DIR] [--skip-warmup]

In an empty Numba cache (a new temporary directory, or --cache), runs
`raytrace warmup --all`, then each command below in a fresh process and
reads its "Compile/load time" (time.compile_s of --json), and each API call
as the first call of a fresh process (NumPy, Numba and the module imported
before the clock starts): its first call's time and a second call's, whose
difference is the compile or cache load.  Issue 46's figure: every one
under 0.5 s.  Markdown on stdout.
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

LIMIT_S = 0.5
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
    ["whitted"], ["glass_teapot"], ["textured"], ["assets/toys.obj", "--view", "front"],
    ["whitted", "--shadows", "soft"], ["textured", "--accel", "grid"],
    ["teapot", "--turntable", "2", "-o", "spin.gif"],
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


def first_and_second(call, env):
    code = (API_SETUP + f"\nt0 = time.perf_counter(); {call}; t1 = time.perf_counter()\n"
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


@click.command()
@click.option("--cache", type=click.Path(file_okay=False), default=None,
              help="Numba cache directory [default: a new empty one].")
@click.option("--skip-warmup", is_flag=True, help="The cache is warm already.")
def main(cache, skip_warmup):
    with tempfile.TemporaryDirectory(prefix="warm-all-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache or str(Path(tmp) / "cache"),
                   RAYTRACE_QUIET="1")
        if not skip_warmup:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "raytrace", "warmup", "--all", "-q"], env=env,
                           check=True)
            print(f"`raytrace warmup --all`: {time.perf_counter() - t0:.0f} s\n")
        print("| command | Compile/load s | whole command s | |")
        print("|---|---:|---:|---|")
        for args in COMMANDS:
            c, wall, err = command(args, env, tmp)
            flag = err or ("over 0.5 s" if c > LIMIT_S else "")
            shown = " ".join(a if a != "HEAT" else "heat.png" for a in args)
            print(f"| `raytrace {shown}` | {'-' if c is None else f'{c:.3f}'} | {wall:.2f} | {flag} |",
                  flush=True)
        print("\n| API call, first in its process | first s | second s | first - second | |")
        print("|---|---:|---:|---:|---|")
        for name, call in API.items():
            first, second, err = first_and_second(call, env)
            if first is None:
                print(f"| {name} | - | - | - | {err} |", flush=True)
                continue
            extra = first - second
            print(f"| {name} | {first:.3f} | {second:.3f} | {extra:.3f} | "
                  f"{'over 0.5 s' if extra > LIMIT_S else ''} |", flush=True)


if __name__ == "__main__":
    main()
