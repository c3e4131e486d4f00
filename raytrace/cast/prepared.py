"""A RayScene's objects as the kernels see them: flattened buffers, the
structure, the counting layout and the BVH the point queries walk, built
on first use, and the surface (ids, normals, points) at hits."""
import numpy as np

from raytrace.errors import RaytraceError
from raytrace.scene.model import Scene


def query_geometry(objects):
    """flatten's (geometry, object ranges, _, (object, face) of each
    primitive) of a RayScene's objects: no shading normals, as a ray query
    reports the geometric normal."""
    from raytrace.scene.flatten import flatten
    return flatten(Scene(name="rays", camera=None, objects=objects), with_sources=True,
                   shading=False)


class _Prepared:
    """A built scene: kernel buffers, the structure, and the maps from the
    kernel's unified primitive ids back to the user's geometry and faces."""

    def __init__(self, objects, accel):
        from raytrace.accel.registry import build_structure
        self.geo, self.obj_ranges, _, (self.prim_object, self.prim_face) = query_geometry(objects)
        self.accel = accel
        self.acc, self.build_s = build_structure(accel, self.geo, self.obj_ranges)
        self.n_tris = self.geo.tri_v0.shape[0]
        # The query kernels' compiled entry points for this scene's types
        # (kernels/entry.py entry_of).
        self.entries = {}
        self._scenes = {}
        self._counting = None
        self._bvh = None
        self._bounds = None
        self._tables = None

    def __getstate__(self):
        # Compiled entry points are this process's (and do not pickle): a
        # copy on a Dask worker finds its own at its first call.
        return dict(self.__dict__, entries={}, _scenes={}, _tables=None)

    def scene(self, layout):
        """The geometry and a layout as the queries' kernels take them
        (kernels/cast.py ray_scene), made once: ``layout`` "rays" the
        structure, "counting" the layout that counts and lists every hit,
        "points" the BVH the point queries walk."""
        scene = self._scenes.get(layout)
        if scene is None:
            from raytrace.kernels.cast import ray_scene
            made = {"rays": lambda: self.acc, "counting": self.counting, "points": self.bvh}
            scene = self._scenes[layout] = ray_scene(self.geo, made[layout]())
        return scene

    def bounds(self):
        """(lo, hi) of the bounded primitives (triangles, spheres); None if
        there are none."""
        if self._bounds is None:
            g = self.geo
            lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
            for k in range(3):    # by column: reductions along axis 0 of (n, 3) are slow
                cols = [a[:, k] for a in (g.tri_v0, g.tri_v1, g.tri_v2)]
                cols += [g.sph_center[:, k] - g.sph_radius, g.sph_center[:, k] + g.sph_radius]
                for c in cols:
                    if len(c):
                        lo[k], hi[k] = min(lo[k], c.min()), max(hi[k], c.max())
            self._bounds = (lo, hi) if lo[0] <= hi[0] else ()
        return self._bounds or None

    def counting(self):
        """The layout that counts and lists every hit (made on first use:
        the BVH's holds a copy of the triangles, registry.Structure.counting_layout)."""
        if self._counting is None:
            from raytrace.accel.registry import get
            self._counting = get(self.accel).counting_layout(self.acc, self.geo)
        return self._counting

    def bvh(self):
        """The BVH that point queries use, whatever structure casts rays."""
        if self._bvh is None:
            from raytrace.accel.registry import build_structure
            self._bvh = (self.acc if self.accel == "bvh"
                         else build_structure("bvh", self.geo, self.obj_ranges)[0])
        return self._bvh

    def ids(self, prim):
        """(geometry id, face) of each unified primitive id, -1 for a miss."""
        return self.geometry_ids(prim), self.faces(prim)

    def geometry_ids(self, prim):
        """The geometry id of each unified primitive id, -1 for a miss."""
        return self._id_tables()[0][prim]

    def faces(self, prim):
        """The face of each unified primitive id, -1 for a miss."""
        return self._id_tables()[1][prim]

    def _id_tables(self):
        """prim_object and prim_face with -1 appended: a miss's id, -1,
        reads that last row, so each map is one gather (a fifth to two
        fifths of the time the hits' rows took, gathered a block at a time:
        docs/benchmarks.md)."""
        if self._tables is None:
            self._tables = tuple(np.append(a, -1).astype(np.int64)
                                 for a in (self.prim_object, self.prim_face))
        return self._tables

    def hit_fields(self, prim, t, u, v):
        """(t, geometry_id, prim_id, uv (n, 2), normal (n, 3)) of closest
        hits in Open3D's dtypes (float32, uint32; a miss: t inf, ids
        2**32 - 1, uv and normal 0), in one pass: kernels/hit_fields.py.
        Triangles only, as the Open3D drop-in adds them."""
        g = self.geo
        if g.sph_center.shape[0] + g.pl_normal.shape[0]:
            raise RaytraceError("hit_fields: a scene of triangles only")
        from raytrace.cast.rays import _blocks as thread_count
        from raytrace.kernels.hit_fields import hit_fields
        return hit_fields(prim, t, u, v, self.prim_object, self.prim_face,
                          g.tri_v0, g.tri_v1, g.tri_v2, thread_count(len(prim)))

    def surface(self, field, prim, u, v, t, origins, directions, rows=None):
        """The unit geometric normal or the point (``field``: "normal" or
        "point") of each hit, NaN rows for misses.  Hit i's ray is row i of
        ``origins`` and ``directions``, or row ``rows[i]`` (a HitList's)."""
        out = np.full((len(prim), 3), np.nan)
        for s in _blocks(len(prim)):
            r = s if rows is None else rows[s]
            self._surface_block(field, out[s], prim[s], u[s], v[s], t[s], origins[r], directions[r])
        return out

    def _surface_block(self, field, out, prim, u, v, t, origins, directions):
        g = self.geo
        n_tris, n_sph = self.n_tris, g.sph_center.shape[0]
        tri = np.flatnonzero((prim >= 0) & (prim < n_tris))
        if len(tri):
            p = prim[tri]
            a, b, c = g.tri_v0[p], g.tri_v1[p], g.tri_v2[p]
            if field == "point":
                uu, vv = u[tri, None], v[tri, None]
                out[tri] = (1.0 - uu - vv) * a + uu * b + vv * c
            else:
                from raytrace.scene.flatten import cross_rows, unit_rows
                out[tri] = unit_rows(cross_rows(b - a, c - a))
        if n_sph + g.pl_normal.shape[0] == 0:    # triangles only: the usual scene
            return
        sph = np.flatnonzero((prim >= n_tris) & (prim < n_tris + n_sph))
        if len(sph):
            k = prim[sph] - n_tris
            c, r = g.sph_center[k], g.sph_radius[k, None]
            d = origins[sph] + t[sph, None] * directions[sph] - c
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            out[sph] = d if field == "normal" else c + r * d
        pl = np.flatnonzero(prim >= n_tris + n_sph)
        if len(pl):
            k = prim[pl] - n_tris - n_sph
            nn, q = g.pl_normal[k], g.pl_point[k]
            if field == "normal":
                out[pl] = nn
            else:
                x = origins[pl] + t[pl, None] * directions[pl]
                out[pl] = x - np.einsum("ij,ij->i", x - q, nn)[:, None] * nn


# Hits a block when ids, normals and points are made: whole, a batch's
# temporaries were several times its answer (docs/benchmarks.md, "Ray queries").
SURFACE_BLOCK = 1 << 16


def _blocks(n):
    """Slices of at most SURFACE_BLOCK rows covering range(n)."""
    return [slice(lo, min(n, lo + SURFACE_BLOCK)) for lo in range(0, n, SURFACE_BLOCK)]


def _mesh_arrays(mesh, faces=None):
    """(vertices, faces) from a pair, from two arguments, or from an object
    with .vertices and .faces (a trimesh.Trimesh, a raytrace Mesh)."""
    if faces is not None:
        return mesh, faces
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return mesh.vertices, mesh.faces
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        return mesh
    kind = type(mesh)
    raise RaytraceError("target must be a (vertices, faces) pair, a mesh with .vertices and "
                        ".faces (such as a trimesh.Trimesh), a trimesh.Scene or a raytrace "
                        f"Scene; got {kind.__module__}.{kind.__qualname__}")


def _trimesh_scene_meshes(target):
    """(vertices, faces, node name) of each mesh a trimesh.Scene places
    (trimesh.load's answer for a GLB or an OBJ of several objects), in the
    order of its graph's geometry nodes, moved by the node's transform as
    trimesh's own dump() moves it (formats/mesh.placed: mirrored faces
    flipped); None if ``target`` is no trimesh.Scene.
    Geometry without faces (points, paths) is left out: no ray hits it."""
    if not type(target).__module__.startswith("trimesh.") or not hasattr(target, "graph"):
        return None
    import trimesh

    from raytrace.scene.formats.mesh import placed
    meshes = []
    for node in target.graph.nodes_geometry:
        matrix, name = target.graph[node]
        mesh = target.geometry[name]
        if isinstance(mesh, trimesh.Trimesh) and len(mesh.faces):
            moved = placed(trimesh, mesh, matrix)
            meshes.append((moved.vertices, moved.faces, str(node)))
    if not meshes:
        raise RaytraceError("target: the trimesh.Scene places no mesh with faces")
    return meshes
