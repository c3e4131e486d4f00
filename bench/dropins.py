"""What the drop-ins cost over RayScene: each trimesh and Open3D drop-in
call against the RayScene call that answers it (reading the same fields),
on inputs the drop-ins were not tuned on: two meshes, three ray sets, each
in float64 and float32; interleaved (the order swapped each round),
medians of REPS.

    PYTHONPATH=. python bench/dropins.py [--reps 9] [--meshes sphere,teapot]
        [--sets camera,shuffled,box] [--dtypes f64,f32] [--calls control,list]

Meshes: a 20,480-triangle icosphere and the teapot alone at detail 43
(118,336 triangles, bench/workload.py's).  Ray sets, WIDTH x HEIGHT =
200,000 rays each (workload.py's): ``camera`` (pixel centres, image
order; the teapot's scene camera, and one looking at the sphere from
3 radii), ``shuffled`` (the same in a random order), ``box`` (from a
sphere around the mesh's box to uniform points of the box); ``f32``: the
same arrays as float32 (Open3D's rays are (n, 6) rows, of the set's dtype).

Ratio: the drop-in's median over RayScene's; ``paired``: the median of the
rounds' ratios (each round's two calls run back to back, so a load change
between rounds cancels).  The control row times one RayScene call against
itself: how far from 1 the machine's load puts a ratio.
"""
import argparse
import time

import numpy as np
import trimesh
from workload import SEED, box_rays, camera_rays, shuffled, teapot_mesh

from raytrace import RayScene
from raytrace.cast.open3d_scene import RaycastingScene
from raytrace.cast.trimesh_ray import RayMeshIntersector
from raytrace.scene.model import Camera

WIDTH, HEIGHT = 500, 400
REPS = 9
TEAPOT_DETAIL = 43


def meshes(names):
    """{name: (vertices, faces, camera)}."""
    out = {}
    if "sphere" in names:
        s = trimesh.creation.icosphere(subdivisions=5)
        out["sphere"] = (np.asarray(s.vertices), np.asarray(s.faces, np.int64),
                         Camera(eye=(0.4, 0.7, 3.0), look_at=(0.0, 0.0, 0.0), fov=45.0))
    if "teapot" in names:
        v, f, camera, _ = teapot_mesh(TEAPOT_DETAIL)
        out["teapot"] = (v, f, camera)
    return out


def ray_sets(v, camera, names, dtypes):
    """{set name: (origins, directions)}, C-contiguous, of each dtype."""
    rng = np.random.default_rng(SEED)
    o, d = camera_rays(camera, WIDTH, HEIGHT)
    base = {"camera": (o, d)}
    so, sd, _ = shuffled((o, d), rng)
    base["shuffled"] = (so, sd)
    base["box"] = box_rays(v.min(axis=0), v.max(axis=0), len(o), rng)
    out = {}
    for name in names:
        for dt in dtypes:
            a, b = base[name]
            t = np.float64 if dt == "f64" else np.float32
            out[f"{name} {dt}"] = (np.ascontiguousarray(a, t), np.ascontiguousarray(b, t))
    return out


def pairs(v, f, o, d):
    """{call: (drop-in call, RayScene call reading the same fields)}."""
    mesh = trimesh.Trimesh(v, f, process=False)
    rs = RayScene((v, f))
    mesh.ray = RayMeshIntersector(mesh)
    o3 = RaycastingScene(tensors=False)
    o3.add_triangles(v, f)
    rays = np.ascontiguousarray(np.concatenate([o, d], axis=1))

    def open3d_fields():
        h = rs.cast_rays(rays, t_min=-1)
        return h.t, h.geometry_id, h.prim_id, h.u, h.v, h.normal

    def open3d_listing():
        h = rs.list_intersections(rays, t_min=-1)
        return h.ray_splits, h.ray_id, h.geometry_id, h.prim_id, h.u, h.v, h.t

    return {
        # The same call twice: the spread this machine puts on a ratio of 1.
        "control: cast_rays().prim_id / the same call":
            (lambda: rs.cast_rays(o, d, t_min=-1).prim_id,
             lambda: rs.cast_rays(o, d, t_min=-1).prim_id),
        "trimesh intersects_first / cast_rays().prim_id":
            (lambda: mesh.ray.intersects_first(o, d),
             lambda: rs.cast_rays(o, d, t_min=-1).prim_id),
        "trimesh intersects_any / occluded":
            (lambda: mesh.ray.intersects_any(o, d), lambda: rs.occluded(o, d, t_min=-1)),
        "trimesh intersects_location / list_intersections":
            (lambda: mesh.ray.intersects_location(o, d),
             lambda: (lambda h: (h.point, h.ray_id, h.prim_id))(
                 rs.list_intersections(o, d, t_min=-1))),
        "Open3D cast_rays / cast_rays (6 fields)": (lambda: o3.cast_rays(rays), open3d_fields),
        "Open3D test_occlusions / occluded":
            (lambda: o3.test_occlusions(rays), lambda: rs.occluded(rays, t_min=-1)),
        "Open3D count_intersections / count_intersections":
            (lambda: o3.count_intersections(rays),
             lambda: rs.count_intersections(rays, t_min=-1)),
        "Open3D list_intersections / list_intersections": (lambda: o3.list_intersections(rays),
                                                           open3d_listing),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=REPS)
    ap.add_argument("--meshes", default="sphere,teapot")
    ap.add_argument("--sets", default="camera,shuffled,box")
    ap.add_argument("--dtypes", default="f64,f32")
    ap.add_argument("--calls", default="",
                    help="only calls whose name contains one of these (comma-separated)")
    args = ap.parse_args()
    cells = {}
    for mname, (v, f, camera) in meshes(args.meshes.split(",")).items():
        for sname, (o, d) in ray_sets(v, camera, args.sets.split(","),
                                      args.dtypes.split(",")).items():
            for call, fns in pairs(v, f, o, d).items():
                if any(c in call for c in args.calls.split(",")):
                    cells[(f"{mname} ({len(f):,} tris)", sname, call)] = fns
    for ours, base in cells.values():      # compile and build first
        ours(), base()
    times = {cell: ([], []) for cell in cells}
    for rep in range(args.reps):
        for cell, (ours, base) in cells.items():
            # Alternate which goes first, so neither always follows the other.
            order = [(0, ours), (1, base)] if rep % 2 else [(1, base), (0, ours)]
            for k, fn in order:
                t0 = time.perf_counter()
                fn()
                times[cell][k].append(time.perf_counter() - t0)
    print(f"{WIDTH * HEIGHT:,} rays a set, medians of {args.reps}, interleaved")
    print("| mesh | rays | drop-in / RayScene | drop-in | RayScene | ratio | paired |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for (mname, sname, call), (ours, base) in times.items():
        a, b = np.median(ours), np.median(base)
        paired = np.median(np.array(ours) / np.array(base))
        print(f"| {mname} | {sname} | {call} | {a * 1e3:.1f} ms | {b * 1e3:.1f} ms "
              f"| {a / b:.3f} | {paired:.3f} |")


if __name__ == "__main__":
    main()
