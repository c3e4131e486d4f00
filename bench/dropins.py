"""What the drop-ins cost over RayScene: each trimesh and Open3D drop-in
call against the RayScene call that answers it (reading the same fields),
200,000 rays at a 20,480-triangle sphere, interleaved, medians of REPS.

    PYTHONPATH=. python bench/dropins.py
"""
import time

import numpy as np
import trimesh

from raytrace import RayScene
from raytrace.cast.open3d_scene import RaycastingScene
from raytrace.cast.trimesh_ray import RayMeshIntersector

N_RAYS = 200_000
REPS = 15


def main():
    mesh = trimesh.creation.icosphere(subdivisions=5)
    rng = np.random.default_rng(0)
    o = rng.normal(size=(N_RAYS, 3)) * 3
    d = rng.uniform(-0.8, 0.8, (N_RAYS, 3)) - o
    rays32 = np.concatenate([o, d], axis=1).astype(np.float32)
    rs = RayScene(mesh)
    mesh.ray = RayMeshIntersector(mesh)
    o3 = RaycastingScene(tensors=False)
    o3.add_triangles(mesh.vertices, mesh.faces)

    def open3d_fields():
        h = rs.cast_rays(rays32, t_min=-1)
        return h.t, h.geometry_id, h.prim_id, h.u, h.v, h.normal

    pairs = {
        "intersects_first / cast_rays().prim_id":
            (lambda: mesh.ray.intersects_first(o, d),
             lambda: rs.cast_rays(o, d, t_min=-1).prim_id),
        "intersects_any / occluded":
            (lambda: mesh.ray.intersects_any(o, d), lambda: rs.occluded(o, d, t_min=-1)),
        "intersects_location / list_intersections":
            (lambda: mesh.ray.intersects_location(o, d),
             lambda: (lambda h: (h.point, h.ray_id, h.prim_id))(
                 rs.list_intersections(o, d, t_min=-1))),
        "Open3D cast_rays / cast_rays (6 fields)": (lambda: o3.cast_rays(rays32), open3d_fields),
        "Open3D count_intersections / count_intersections":
            (lambda: o3.count_intersections(rays32),
             lambda: rs.count_intersections(rays32, t_min=-1)),
    }
    for ours, base in pairs.values():      # compile and build first
        ours(), base()
    times = {name: ([], []) for name in pairs}
    for rep in range(REPS):
        for name, (ours, base) in pairs.items():
            # Alternate which goes first, so neither always follows the other.
            order = [(0, ours), (1, base)] if rep % 2 else [(1, base), (0, ours)]
            for k, f in order:
                t0 = time.perf_counter()
                f()
                times[name][k].append(time.perf_counter() - t0)
    print(f"{N_RAYS} rays, {len(mesh.faces)} triangles, medians of {REPS}")
    for name, (ours, base) in times.items():
        a, b = np.median(ours), np.median(base)
        print(f"{name:52s} {a * 1e3:8.1f} ms {b * 1e3:8.1f} ms  ratio {a / b:.3f}")


if __name__ == "__main__":
    main()
