"""What a ray and a call cost through RayScene: the README's figures.

    python bench/ray_costs.py [--detail 43] [--runs 7]

The workload suite's ray sets (bench/workload.py: camera rays in image
order, and as float32 arrays, the same shuffled, random rays through the
mesh's box, shadow rays to the point light; 640x480 of each) on the teapot mesh alone, BVH, 2
threads: the median time of a closest-hit and an any-hit call over
``runs`` calls, per ray; then a call of one ray, the median of 3,000.
Markdown on stdout.
"""
import time

import click
import numpy as np
from workload import scene_and_sets


def _median_s(fn, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


@click.command()
@click.option("--detail", default=43, show_default=True, help="teapot tessellation (43: 118k triangles)")
@click.option("--runs", default=7, show_default=True)
def main(detail, runs):
    scene, sets, n_tris = scene_and_sets(detail, 640, 480)
    print(f"### What a ray costs: RayScene, BVH, {n_tris:,} triangles, 2 threads\n")
    print("| rays | count | closest us/ray | any us/ray |\n| --- | ---: | ---: | ---: |")
    o, d, tm = sets["camera"]
    sets["camera f32"] = (o.astype(np.float32), d.astype(np.float32), tm)
    for name in ("camera", "camera f32", "shuffled", "box", "shadow-point"):
        o, d, tm = sets[name]
        scene.cast_rays(o, d, t_max=tm)
        scene.occluded(o, d, t_max=tm)
        c = _median_s(lambda o=o, d=d, tm=tm: scene.cast_rays(o, d, t_max=tm), runs)
        a = _median_s(lambda o=o, d=d, tm=tm: scene.occluded(o, d, t_max=tm), runs)
        print(f"| {name} | {len(o):,} | {c / len(o) * 1e6:.3f} | {a / len(o) * 1e6:.3f} |")
    o, d = sets["camera"][0][:1], sets["camera"][1][:1]
    one = _median_s(lambda: scene.cast_rays(o, d), 3000)
    any_one = _median_s(lambda: scene.occluded(o, d), 3000)
    print(f"\nA call of one ray: cast_rays {one * 1e6:.1f} us, occluded {any_one * 1e6:.1f} us.")


if __name__ == "__main__":
    main()
