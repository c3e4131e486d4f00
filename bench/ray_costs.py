"""What a ray and a call cost through RayScene: the README's figures.

    python bench/ray_costs.py [--detail 43] [--runs 7]

The workload suite's ray sets (bench/workload.py: camera rays in image
order, and as float32 arrays, the same shuffled, random rays through the
mesh's box, shadow rays to the point light; 640x480 of each) on the teapot mesh alone, BVH, 2
threads: the median time of a closest-hit and an any-hit call over
``runs`` calls, per ray; then a call of one ray, against Open3D and
Embree where they import (the ``peers`` extra).
Markdown on stdout.
"""
import time

import click
import numpy as np
from workload import scene_and_sets, teapot_mesh


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
    calls = {"RayScene": (lambda: scene.cast_rays(o, d), lambda: scene.occluded(o, d))}
    calls.update(_peer_calls(detail, o, d))
    # Rounds of 300 calls, each caller in turn (one noisy stretch of the
    # machine then slows every column), the median round per call.
    rounds = {(name, q): [] for name in calls for q in (0, 1)}
    for _ in range(10):
        for (name, q), times in rounds.items():
            times.append(_median_s(calls[name][q], 300))
    print("\n| a call of one ray | closest us | any us |\n| --- | ---: | ---: |")
    for name in calls:
        c, a = (float(np.median(rounds[name, q])) * 1e6 for q in (0, 1))
        print(f"| {name} | {c:.1f} | {a:.1f} |")


def _peer_calls(detail, o, d):
    """(closest, any hit) callers of one ray (o, d) for the peers that
    import, on the same triangles, rays made before timing in each peer's
    own type: what a caller holding them pays."""
    calls = {}
    v, f = teapot_mesh(detail)[:2]
    v = v.astype(np.float32)
    try:
        import open3d as o3d
        s = o3d.t.geometry.RaycastingScene()
        s.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
        r = o3d.core.Tensor(np.hstack([o, d]).astype(np.float32))
        calls[f"Open3D {o3d.__version__} RaycastingScene"] = (lambda: s.cast_rays(r),
                                                              lambda: s.test_occlusions(r))
    except ImportError:
        pass
    try:
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
        e = rtcs.EmbreeScene()
        TriangleMesh(e, v, f)
        o32, d32 = o.astype(np.float32), d.astype(np.float32)
        calls["Embree (embreex) EmbreeScene.run"] = (lambda: e.run(o32, d32),
                                                      lambda: e.run(o32, d32, query="OCCLUDED"))
    except ImportError:
        pass
    for closest, any_hit in calls.values():    # builds and first-call costs, untimed
        closest(), any_hit()
    return calls


if __name__ == "__main__":
    main()
