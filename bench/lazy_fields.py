"""What reading each lazy field of a RayHits costs: the answer's size, the
peak tracemalloc sees while it is made, and the time.

    python bench/lazy_fields.py [--rays 1e7] [FIELD ...]

Rays from z = 5 down at an icosphere (subdivision 3), most of them hits.
"""
import time
import tracemalloc

import click
import numpy as np


@click.command()
@click.option("--rays", default=1e7, show_default=True, help="How many rays.")
@click.argument("fields", nargs=-1)
def main(rays, fields):
    import trimesh

    import raytrace
    n = int(rays)
    rng = np.random.default_rng(0)
    origins = np.tile([0.0, 0.0, 5.0], (n, 1))
    directions = np.c_[rng.uniform(-0.25, 0.25, (n, 2)), -np.ones(n)]
    hits = raytrace.RayScene(trimesh.creation.icosphere(3)).cast_rays(origins, directions)
    for name in fields or ("normal", "point", "geometry_id", "u"):
        tracemalloc.start()
        t0 = time.perf_counter()
        answer = getattr(hits, name)
        seconds = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(f"{name}: answer {answer.nbytes / 1e6:.0f} MB, peak {peak / 1e6:.0f} MB, {seconds:.2f} s")


if __name__ == "__main__":
    main()
