"""A drop-in for trimesh's ray queries: ``RayMeshIntersector`` answers the
calls of ``trimesh.ray.ray_triangle.RayMeshIntersector`` (and of its Embree
twin) with their arguments and return conventions, through a RayScene:

    import raytrace.cast.trimesh_ray
    mesh.ray = raytrace.cast.trimesh_ray.RayMeshIntersector(mesh)

after which ``mesh.ray.intersects_location(...)`` and the rest run on
raytrace's kernels (float64, watertight, each crossing counted once).
"""
import numpy as np

from raytrace.cast.rayscene import RayScene


class RayMeshIntersector:
    def __init__(self, mesh, accel="bvh"):
        self.mesh = mesh
        self._scene = RayScene((mesh.vertices, mesh.faces), accel=accel)

    def intersects_id(self, ray_origins, ray_directions, return_locations=False,
                      multiple_hits=True, max_hits=20, **kwargs):
        """(index_tri, index_ray[, locations]) of the hits: every hit of each
        ray (at most max_hits, nearest first) or only its first."""
        if multiple_hits:
            h = self._scene.list_intersections(ray_origins, ray_directions, max_hits=max_hits)
            tri, ray = h.prim_id, h.ray_id
            if return_locations:
                return tri, ray, h.point
        else:
            h = self._scene.cast_rays(ray_origins, ray_directions)
            hit = h.hit
            tri, ray = h.prim_id[hit], np.flatnonzero(hit)
            if return_locations:
                return tri, ray, h.point[hit]
        return tri, ray

    def intersects_location(self, ray_origins, ray_directions, multiple_hits=True, **kwargs):
        """(locations, index_ray, index_tri) of the hits."""
        tri, ray, loc = self.intersects_id(ray_origins, ray_directions, return_locations=True,
                                           multiple_hits=multiple_hits, **kwargs)
        return loc, ray, tri

    def intersects_first(self, ray_origins, ray_directions, **kwargs):
        """The index of the first triangle each ray hits, -1 for a miss."""
        return self._scene.cast_rays(ray_origins, ray_directions).prim_id

    def intersects_any(self, ray_origins, ray_directions, **kwargs):
        """Whether each ray hits the mesh at all."""
        return self._scene.occluded(ray_origins, ray_directions)

    def contains_points(self, points):
        """Whether each point is inside the mesh (RayScene.contains)."""
        return self._scene.contains(points)
