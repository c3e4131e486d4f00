"""What sorting rays would buy RayScene (an experiment, not in the
library): rays put in Morton order of their origin and octahedral direction
(Garanzha & Loop 2010, "Fast Ray Sorting and Breadth-First Packet
Traversal for GPU Ray Tracing"), traced in that order, against the order
given.  Trace time alone, then what the key and the sort cost in NumPy.

    python bench/ray_sorting.py [--detail 43] [--width 320 --height 240]

The workload suite's ray sets (bench/workload.py), BVH, 2 threads, medians
of 7 calls.  Markdown on stdout.  docs/benchmarks.md ("Compile time and
ray order, round 3") has a run and why the library does not sort.
"""
import time

import click
import numpy as np
from workload import scene_and_sets

# Key bits shared out among the dimensions that vary over the rays (origin
# x, y, z; direction u, v), at most MAX_BITS each.
KEY_BITS = 60
MAX_BITS = 20


def features(origins, dirs):
    """(m, n) coordinates in [0, 1] of those of the 5 that vary: the origin
    in the origins' bounds, the direction on the octahedral map."""
    d = dirs / np.abs(dirs).sum(axis=1)[:, None]
    u, v, z = d[:, 0], d[:, 1], d[:, 2]
    lower = z < 0.0
    fu = np.where(lower, (1.0 - np.abs(v)) * np.copysign(1.0, u), u)
    fv = np.where(lower, (1.0 - np.abs(u)) * np.copysign(1.0, v), v)
    out = []
    for c in (origins[:, 0], origins[:, 1], origins[:, 2], fu, fv):
        lo, hi = c.min(), c.max()
        if hi > lo:
            out.append((c - lo) / (hi - lo))
    return np.array(out)


def morton(feats):
    """uint64 Morton keys of points in [0, 1]^m (feats: (m, n)), a byte of
    each coordinate at a time through a table spreading its bits m apart."""
    m = feats.shape[0]
    bits = min(MAX_BITS, KEY_BITS // m)
    q = np.minimum((feats * (1 << bits)).astype(np.uint64), np.uint64((1 << bits) - 1))
    i = np.arange(256, dtype=np.uint64)
    table = np.zeros(256, np.uint64)
    for b in range(8):
        table |= ((i >> np.uint64(b)) & np.uint64(1)) << np.uint64(m * b)
    key = np.zeros(feats.shape[1], np.uint64)
    for k in range(m):
        for byte in range(0, bits, 8):
            key |= table[(q[k] >> np.uint64(byte)) & np.uint64(255)] << np.uint64(m * byte + k)
    return key


def _median_ms(fn, runs=7):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) * 1e3


@click.command()
@click.option("--detail", default=43, show_default=True)
@click.option("--width", default=320, show_default=True)
@click.option("--height", default=240, show_default=True)
def main(detail, width, height):
    scene, sets, n_tris = scene_and_sets(detail, width, height)
    print(f"### Sorting rays: RayScene, BVH, {n_tris:,} triangles, trace time in ms\n")
    print("| rays | closest, given order | closest, sorted | any, given order | any, sorted | "
          "key + sort |\n| --- | ---: | ---: | ---: | ---: | ---: |")
    for name in ("camera", "shuffled", "box", "bounce"):
        o, d, tm = sets[name]
        sort_ms = _median_ms(lambda o=o, d=d: np.argsort(morton(features(o, d)), kind="stable"))
        order = np.argsort(morton(features(o, d)), kind="stable")
        so, sd = o[order], d[order]
        cells = []
        for query in (scene.cast_rays, scene.occluded):
            for a, b in ((o, d), (so, sd)):
                query(a, b, t_max=tm)
                cells.append(_median_ms(lambda q=query, a=a, b=b, tm=tm: q(a, b, t_max=tm)))
        print(f"| {name} | " + " | ".join(f"{c:.2f}" for c in cells) + f" | {sort_ms:.1f} |")


if __name__ == "__main__":
    main()
