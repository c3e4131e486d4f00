"""The workload suite's ray sets through this checkout's RayScene and
another checkout's, each against Open3D in the same process: issue 40's
"before and after" table.

    python bench/workload_versus.py OTHER_CHECKOUT [--details 4,43,128] [--rounds 2]

The ray sets are made once by this checkout (bench/workload.py, saved to a
temporary folder), so both trees trace the same rays, including a tree
from before the suite existed.  Each round runs one process a tree, the
trees alternated, each with a kernel cache of its own; in a process, each
row's calls alternate ours and Open3D's, each timed call right after an
untimed one of its own (workload.py says why), medians of 7.  The table
takes each cell's median over the rounds.  Needs Open3D (the ``peers``
extra).  Markdown on stdout.
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import click
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

# Run in each tree's process: RayScene (whichever raytrace is on the path)
# and Open3D on the saved sets.
ONE = r"""
import json, sys, time
import numpy as np, numba
numba.set_num_threads(2)
import open3d as o3d
from raytrace import RayScene
folder, details, rows = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
out = {}
for detail in map(int, details.split(",")):
    z = np.load(f"{folder}/d{detail}.npz")
    v, f = z["v"], z["f"]
    sc = RayScene((v, f))
    o3 = o3d.t.geometry.RaycastingScene(nthreads=2)
    o3.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
    def rays(o, d):
        return o3d.core.Tensor(np.hstack([o, d]).astype(np.float32))
    ours = {"closest": lambda o, d, tm: sc.cast_rays(o, d, t_max=tm).prim_id,
            "any": lambda o, d, tm: sc.occluded(o, d, t_max=tm),
            "count": lambda o, d, tm: sc.count_intersections(o, d, t_max=tm)}
    theirs = {"closest": lambda o, d, tm: o3.cast_rays(rays(o, d))["primitive_ids"].numpy(),
              "any": lambda o, d, tm: o3.test_occlusions(rays(o, d), tfar=tm).numpy(),
              "count": lambda o, d, tm: o3.count_intersections(rays(o, d)).numpy()}
    for name, queries in rows:
        o, d, tm = z[name + "|o"], z[name + "|d"], float(z[name + "|t"])
        o32, d32 = o.astype(np.float32), d.astype(np.float32)
        for q in queries:
            calls = (lambda: ours[q](o, d, tm), lambda: theirs[q](o32, d32, tm))
            times = ([], [])
            for fn in calls:
                fn()
            for _ in range(7):
                for fn, ts in zip(calls, times):
                    fn()
                    t0 = time.perf_counter()
                    fn()
                    ts.append(time.perf_counter() - t0)
            out[f"{len(f)}|{name}|{q}"] = [float(np.median(ts)) * 1e3 for ts in times]
print(json.dumps(out))
"""


def save_sets(folder, details):
    """Each detail's mesh and ray sets (float32 sets as float32) into folder."""
    import workload

    from raytrace import RayScene
    for detail in details:
        v, f, camera, light = workload.teapot_mesh(detail)
        scene = RayScene((v, f))

        def closest(o, d, scene=scene):
            h = scene.cast_rays(o, d)
            return h.prim_id, h.t
        arrays = {"v": v, "f": f}
        for name, (o, d, tm) in workload.ray_sets(v, f, camera, light, closest, 640, 480).items():
            arrays.update({name + "|o": o, name + "|d": d, name + "|t": np.asarray(tm, float)})
        np.savez(f"{folder}/d{detail}.npz", **arrays)


@click.command()
@click.argument("other", type=click.Path(exists=True, file_okay=False))
@click.option("--details", default="4,43,128", show_default=True)
@click.option("--rounds", default=2, show_default=True)
def main(other, details, rounds):
    from workload import ROWS
    with tempfile.TemporaryDirectory() as folder:
        save_sets(folder, [int(x) for x in details.split(",")])
        trees = {"this": ROOT, "other": Path(other).resolve()}
        got = {k: [] for k in trees}
        for _ in range(rounds):
            for key, tree in trees.items():
                env = dict(os.environ, PYTHONPATH=str(tree), RAYTRACE_QUIET="1",
                           NUMBA_CACHE_DIR=f"{folder}/cache-{key}")
                run = subprocess.run([sys.executable, "-c", ONE, folder, details, json.dumps(ROWS)],
                                     env=env, capture_output=True, text=True, cwd=folder)
                if run.returncode:
                    sys.exit(f"workload_versus: the {key} tree's run failed:\n{run.stderr[-2000:]}")
                got[key].append(json.loads(run.stdout.splitlines()[-1]))
    print("| triangles | rays | query | other: ours / Open3D ms (Open3D over ours) "
          "| this: ours / Open3D ms (Open3D over ours) | ours, other over this |\n"
          "| ---: | --- | --- | --- | --- | ---: |")
    for cell in got["this"][0]:
        (oa, ob), (ta, tb) = ([float(np.median([r[cell][i] for r in got[k]])) for i in (0, 1)]
                              for k in ("other", "this"))
        n, name, q = cell.split("|")
        print(f"| {int(n):,} | {name} | {q} | {oa:.1f} / {ob:.1f} ({ob / oa:.2f}) "
              f"| {ta:.1f} / {tb:.1f} ({tb / ta:.2f}) | {oa / ta:.2f} |")


if __name__ == "__main__":
    main()
