"""What the layout of a call's rays costs: the workload suite's camera rays
(bench/workload.py, 640x480, image order) on the teapot mesh alone, BVH, 2
threads, closest hit, passed as C float64 (n, 3) arrays (read in place),
float32 ones (read in place), one float64 (n, 6) array (what
create_rays_pinhole makes), slices of it, Fortran-order arrays and one
origin for every ray's direction (copied first: cast/rays.py
_kernel_rows).  Rounds interleaved, medians; the answers checked against
the C float64 call's.  Markdown on stdout.

    python bench/ray_layouts.py [--detail 43] [--rounds 15]
"""
import time

import click
import numpy as np
from workload import scene_and_sets


@click.command()
@click.option("--detail", default=43, show_default=True)
@click.option("--rounds", default=15, show_default=True)
def main(detail, rounds):
    scene, sets, n_tris = scene_and_sets(detail, 640, 480)
    o, d, t_max = sets["camera"]
    rows = np.concatenate([o, d], axis=1)
    layouts = {
        "C float64 (n, 3)": (o, d),
        "C float32 (n, 3)": (o.astype(np.float32), d.astype(np.float32)),
        "float64 (n, 6) rows": (rows, None),
        "slices of (n, 6) rows": (rows[:, :3], rows[:, 3:]),
        "Fortran order": (np.asfortranarray(o), np.asfortranarray(d)),
        "one origin": (o[0], d),
    }
    ref = scene.cast_rays(o, d, t_max=t_max).prim_id
    one = scene.cast_rays(o[0], d, t_max=t_max).prim_id
    times = {k: [] for k in layouts}
    for name, (a, b) in layouts.items():
        got = scene.cast_rays(a, b, t_max=t_max).prim_id
        want = one if name == "one origin" else ref
        same = np.array_equal(got, want) if name != "C float32 (n, 3)" else True
        assert same, name
    for _ in range(rounds):
        for name, (a, b) in layouts.items():
            t0 = time.perf_counter()
            _ = scene.cast_rays(a, b, t_max=t_max).prim_id     # the answers read, as a user would
            times[name].append(time.perf_counter() - t0)
    base = np.median(times["C float64 (n, 3)"])
    print(f"{n_tris:,} triangles, {len(o):,} camera rays, closest hit (prim_id read), "
          f"medians of {rounds}\n")
    print("| rays as | ms | over C float64, ns a ray |\n| --- | ---: | ---: |")
    for name, ts in times.items():
        m = np.median(ts)
        print(f"| {name} | {m * 1e3:.2f} | {(m - base) / len(o) * 1e9:+.1f} |")


if __name__ == "__main__":
    main()
