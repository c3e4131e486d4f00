"""A drop-in for trimesh's ray queries: ``RayMeshIntersector`` answers the
calls of ``trimesh.ray.ray_triangle.RayMeshIntersector`` and of its Embree
twin with their arguments, return types and orders, through a RayScene:

    import raytrace.cast.trimesh_ray
    raytrace.cast.trimesh_ray.install()     # every mesh made from now on
    mesh.ray = raytrace.cast.trimesh_ray.RayMeshIntersector(mesh)   # or one mesh

after which ``mesh.ray.intersects_location(...)``, ``mesh.contains(...)``
and the rest of trimesh that casts rays run on raytrace's kernels (float64,
watertight, each crossing of the surface counted once).
"""
import numpy as np

from raytrace.errors import RaytraceError

# A t_min below 0: hits at the ray's origin count (rayscene.py), as in
# trimesh's ray_triangle (which keeps hits down to t = -1e-6) and Embree.
_FROM_ORIGIN = -1.0


def _has(obj, name):
    """Whether obj has the attribute, by its class or its own fields: not
    by reading it, which a trimesh primitive being made cannot answer yet."""
    return hasattr(type(obj), name) or name in getattr(obj, "__dict__", {})


def _mesh_key(mesh):
    """What says the mesh changed: trimesh's hash of its data (it changes
    with the vertices and faces, as trimesh's own caches use it); None for
    an object with no hash of its arrays, read once."""
    try:
        return mesh.__hash__()
    except TypeError:
        return None


class RayMeshIntersector:
    """trimesh's ``mesh.ray``: ray queries against ``mesh`` (a
    trimesh.Trimesh, or anything with .vertices and .faces).

    Making one reads nothing: the mesh is read at the first query, and
    again whenever its hash changes (after ``apply_translation`` and the
    like), as trimesh's intersectors do; a primitive (``trimesh.primitives.
    Box``...) or a 2D mesh may make one before it has 3D triangles.
    ``scale_to_box`` is Embree's argument, accepted and not needed (float64
    needs no rescaling); ``accel`` is the structure (RayScene's).

    As trimesh counts them, a ray hits a face it starts on (t = 0); a ray
    with a zero or NaN direction or origin misses.  Every hit of a ray
    (multiple_hits) is one crossing of the surface, so a ray through an
    edge or vertex between faces hits one of them once, where trimesh's
    ray_triangle reports each face (its locations, deduplicated, agree).
    Hits come ray by ray (index_ray ascending), nearest first.
    """
    _depth_order = False       # EmbreeRayMeshIntersector: hit rank first
    _max_hits = None           # per ray, by default

    def __init__(self, mesh, scale_to_box=True, accel="bvh"):
        from raytrace.accel.registry import get
        get(accel)
        if not (_has(mesh, "vertices") and _has(mesh, "faces")):
            raise RaytraceError(f"mesh: expected a mesh with .vertices and .faces (a trimesh.Trimesh), "
                                f"got {type(mesh).__name__}")
        self.mesh = mesh
        self._scale_to_box = scale_to_box
        self.accel = accel
        self._scene = None
        self._key = None

    def _rays(self):
        """The RayScene of the mesh as it is now (built again if it changed),
        or None for a mesh without faces."""
        key = _mesh_key(self.mesh)
        if self._scene is None or key != self._key:
            from raytrace.cast.rayscene import RayScene
            faces = self.mesh.faces
            if faces is None or len(faces) == 0:
                scene = False
            else:
                scene = RayScene(accel=self.accel)
                scene._check = False        # bad rays miss, as trimesh's engines answer them
                scene.add_mesh(self.mesh.vertices, faces)
            self._scene, self._key = scene, key
        return self._scene or None

    def intersects_id(self, ray_origins, ray_directions, return_locations=False,
                      multiple_hits=True, max_hits=None, **kwargs):
        """(index_tri, index_ray[, locations]) of the hits: int64, int64,
        (h, 3) float64.  Every hit of each ray (at most ``max_hits``, the
        nearest) or only its first."""
        scene = self._rays()
        if scene is None:
            out = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)))
            return out if return_locations else out[:2]
        if multiple_hits:
            limit = self._max_hits if max_hits is None else max_hits
            h = scene.list_intersections(ray_origins, ray_directions, t_min=_FROM_ORIGIN,
                                         max_hits=limit)
            tri, ray = h.prim_id, h.ray_id
            rows = None
            if self._depth_order:         # each ray's first hit, then each second...
                rank = np.arange(len(ray)) - h.ray_splits[ray]
                rows = np.argsort(rank, kind="stable")
                tri, ray = tri[rows], ray[rows]
            if return_locations:
                loc = h.point if rows is None else h.point[rows]
        else:
            h = scene.cast_rays(ray_origins, ray_directions, t_min=_FROM_ORIGIN)
            hit = h.hit
            ray = np.flatnonzero(hit)
            tri = h.prim_id[ray]
            if return_locations:
                loc = h.point[ray]
        tri, ray = tri.astype(np.int64, copy=False), ray.astype(np.int64, copy=False)
        return (tri, ray, loc) if return_locations else (tri, ray)

    def intersects_location(self, ray_origins, ray_directions, multiple_hits=True, **kwargs):
        """(locations, index_ray, index_tri) of the hits."""
        tri, ray, loc = self.intersects_id(ray_origins, ray_directions, return_locations=True,
                                           multiple_hits=multiple_hits, **kwargs)
        return loc, ray, tri

    def intersects_first(self, ray_origins, ray_directions, **kwargs):
        """The index of the first face each ray hits, -1 for a miss: (n,) int64."""
        scene = self._rays()
        if scene is None:
            return np.full(len(np.asarray(ray_origins)), -1, np.int64)
        return scene.cast_rays(ray_origins, ray_directions, t_min=_FROM_ORIGIN).prim_id

    def intersects_any(self, ray_origins, ray_directions, **kwargs):
        """Whether each ray hits the mesh at all: (n,) bool."""
        scene = self._rays()
        if scene is None:
            return np.zeros(len(np.asarray(ray_origins)), bool)
        return scene.occluded(ray_origins, ray_directions, t_min=_FROM_ORIGIN)

    def contains_points(self, points):
        """Whether each point is inside the mesh (RayScene.contains: the
        parity of one ray's crossings, exact on a closed mesh)."""
        scene = self._rays()
        if scene is None:
            return np.zeros(len(np.asarray(points)), bool)
        return scene.contains(points)

    def __getstate__(self):
        # The built scene is rebuilt where it is needed, not pickled.
        return {k: v for k, v in self.__dict__.items() if k not in ("_scene", "_key")}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._scene, self._key = None, None

    def __copy__(self):
        return type(self)(self.mesh, scale_to_box=self._scale_to_box, accel=self.accel)

    def __deepcopy__(self, memo):
        return self.__copy__()

    def __repr__(self):
        return f"{type(self).__name__}(accel={self.accel!r})"


class EmbreeRayMeshIntersector(RayMeshIntersector):
    """``trimesh.ray.ray_pyembree.RayMeshIntersector``'s conventions: with
    multiple_hits, every ray's first hit, then every ray's second, and so
    on (Embree's passes), at most ``max_hits=100`` a ray."""
    _depth_order = True
    _max_hits = 100


_ORIGINALS = {}


def install():
    """Make raytrace trimesh's ray engine for every mesh made from now on
    (and for ``trimesh.ray.ray_triangle.RayMeshIntersector(mesh)`` and its
    Embree twin called by name): their classes become RayMeshIntersector
    and EmbreeRayMeshIntersector.  uninstall() puts trimesh's back."""
    import trimesh.ray

    modules = [(trimesh.ray.ray_triangle, RayMeshIntersector)]
    if trimesh.ray.has_embree:
        modules.append((trimesh.ray.ray_pyembree, EmbreeRayMeshIntersector))
    for module, ours in modules:
        _ORIGINALS.setdefault(module.__name__, (module, module.RayMeshIntersector))
        module.RayMeshIntersector = ours


def uninstall():
    """Undo install(): meshes made from now on use trimesh's own engines."""
    for module, theirs in _ORIGINALS.values():
        module.RayMeshIntersector = theirs
    _ORIGINALS.clear()
