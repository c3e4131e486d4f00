"""A drop-in for Open3D's ``open3d.t.geometry.RaycastingScene``: the same
methods, arguments, result keys, dtypes and INVALID_ID conventions,
answered by a RayScene (float64, watertight, each crossing counted once):

    from raytrace.cast.open3d_scene import RaycastingScene
    scene = RaycastingScene()
    scene.add_triangles(mesh)          # an Open3D mesh, or vertex and index arrays
    ans = scene.cast_rays(rays)        # (..., 6) rays: ans["t_hit"], ans["primitive_ids"], ...

Inputs may be NumPy arrays or Open3D tensors (read in place; float32 rays
are converted once, to the kernels' float64).  Answers are Open3D tensors,
as Open3D's own are, when Open3D is imported in the process (or a tensor
was passed), NumPy arrays otherwise (``RaycastingScene(tensors=False)``:
always); raytrace never imports Open3D itself for a caller without it.

As in Open3D, a ray hits a face it starts on (t = 0), and a ray with a
NaN origin or a zero direction misses (RayScene raises for it).
"""
import sys

import numpy as np

from raytrace.errors import RaytraceError

INVALID_ID = 2 ** 32 - 1
# A t_min below 0 counts hits at t = 0 (rayscene.py), as Embree's tnear = 0 does.
_FROM_ORIGIN = -1.0


def _is_tensor(x):
    return type(x).__module__.startswith("open3d")


def _array(x):
    """A NumPy view of an Open3D tensor (or Vector3dVector), or the array."""
    if _is_tensor(x):
        if hasattr(x, "cpu"):
            x = x.cpu()
        return x.numpy() if hasattr(x, "numpy") else np.asarray(x)
    return np.asarray(x)


def _answer(arrays, like, tensors=None):
    """Answers as Open3D tensors (sharing the arrays' memory) if ``like``
    is one, or ``tensors`` is None and Open3D is imported; else as is."""
    if tensors is None:
        tensors = "open3d" in sys.modules
    if not (tensors or _is_tensor(like)):
        return arrays
    import open3d as o3d
    wrap = o3d.core.Tensor.from_numpy
    if isinstance(arrays, dict):
        return {k: wrap(np.ascontiguousarray(a)) for k, a in arrays.items()}
    return wrap(np.ascontiguousarray(arrays))


def _mesh_arrays(mesh):
    """(vertices, triangles) of an Open3D tensor mesh, a legacy Open3D mesh
    or anything with .vertices and .faces."""
    if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):        # open3d.t.geometry
        return _array(mesh.vertex.positions), _array(mesh.triangle.indices)
    if _is_tensor(mesh) and hasattr(mesh, "triangles"):              # open3d.geometry
        return np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return mesh.vertices, mesh.faces
    raise RaytraceError("add_triangles: expected vertex and triangle arrays or a triangle mesh, "
                        f"got {type(mesh).__name__}")


class RaycastingScene:
    """Open3D's RaycastingScene on raytrace's kernels.  ``nthreads``
    arguments are accepted and the kernels use Numba's threads
    (NUMBA_NUM_THREADS); ``device`` must be the CPU.  ``tensors``: answer
    with Open3D tensors (True), NumPy arrays (False), or tensors when
    Open3D is imported (None).  ``accel``: RayScene's structure."""
    INVALID_ID = INVALID_ID

    def __init__(self, nthreads=0, device=None, accel="bvh", tensors=None):
        from raytrace.cast.rayscene import RayScene
        if device is not None and not str(device).upper().startswith("CPU"):
            raise RaytraceError(f"device: raytrace runs on the CPU, got {device}")
        self._scene = RayScene(accel=accel)
        self._scene._check = False          # bad rays miss, as in Open3D
        self._tensors = tensors

    def _answer(self, arrays, like):
        return _answer(arrays, like, self._tensors)

    def add_triangles(self, vertex_positions, triangle_indices=None):
        """Add a mesh; returns its geometry id (0, 1, ...)."""
        if triangle_indices is None:
            v, f = _mesh_arrays(vertex_positions)
        else:
            v, f = _array(vertex_positions), _array(triangle_indices)
        f = np.asarray(f)
        if f.dtype.kind == "u":       # Open3D's uint32 indices
            f = f.astype(np.int64)
        return self._scene.add_mesh(v, f)

    def cast_rays(self, rays, nthreads=0):
        """The closest hit of each (..., 6) ray: t_hit, geometry_ids,
        primitive_ids, primitive_uvs (..., 2), primitive_normals (..., 3);
        a miss has t_hit inf, ids INVALID_ID, uvs and normals 0."""
        h = self._scene.cast_rays(_array(rays), t_min=_FROM_ORIGIN)
        t, geometry, prim, uv, normal = h._hit_fields()
        return self._answer({"t_hit": t, "geometry_ids": geometry, "primitive_ids": prim,
                             "primitive_uvs": uv, "primitive_normals": normal}, rays)

    def test_occlusions(self, rays, tnear=0.0, tfar=np.inf, nthreads=0):
        """Whether anything is hit along each ray between tnear and tfar: bool."""
        tnear = float(tnear)
        hit = self._scene.occluded(_array(rays), t_min=_FROM_ORIGIN if tnear <= 0 else tnear,
                                   t_max=tfar)
        return self._answer(hit, rays)

    def count_intersections(self, rays, nthreads=0):
        """How many times each ray meets the surfaces: int32."""
        return self._answer(self._scene.count_intersections(_array(rays), t_min=_FROM_ORIGIN)
                       .astype(np.int32), rays)

    def list_intersections(self, rays, nthreads=0):
        """Every hit of each ray, flat: ray i's are rows ray_splits[i]:
        ray_splits[i + 1] (nearest first) of t_hit, geometry_ids,
        primitive_ids, primitive_uvs and ray_ids."""
        h = self._scene.list_intersections(_array(rays), t_min=_FROM_ORIGIN)
        return self._answer({"ray_splits": h.ray_splits.astype(np.uint32),
                        "ray_ids": h.ray_id.astype(np.uint32),
                        "geometry_ids": h.geometry_id.astype(np.uint32),
                        "primitive_ids": h.prim_id.astype(np.uint32),
                        "primitive_uvs": np.stack([h.u, h.v], axis=-1).astype(np.float32),
                        "t_hit": h.t.astype(np.float32)}, rays)

    def _points(self, query_points):
        q = _array(query_points)
        if q.ndim < 1 or q.shape[-1] != 3:
            raise RaytraceError(f"query_points: expected shape (..., 3), got {q.shape}")
        return q.reshape(-1, 3), q.shape[:-1]

    def compute_closest_points(self, query_points, nthreads=0):
        """The closest point on the surfaces to each (..., 3) query point:
        points, geometry_ids, primitive_ids, primitive_uvs, primitive_normals."""
        q, shape = self._points(query_points)
        c = self._scene.closest_points(q)
        tri = ~np.isnan(c.u)
        uv = np.zeros((len(q), 2), np.float32)
        uv[tri, 0], uv[tri, 1] = c.u[tri], c.v[tri]
        out = {"points": c.point, "geometry_ids": c.geometry_id.astype(np.uint32),
               "primitive_ids": c.prim_id.astype(np.uint32), "primitive_uvs": uv,
               "primitive_normals": c.normal}
        return self._answer({k: a.reshape(shape + a.shape[1:]).astype(_dtype(k), copy=False)
                        for k, a in out.items()}, query_points)

    def compute_distance(self, query_points, nthreads=0):
        """Distance from each (..., 3) point to the surfaces: float32."""
        q, shape = self._points(query_points)
        return self._answer(self._scene.distance(q).astype(np.float32).reshape(shape), query_points)

    def compute_signed_distance(self, query_points, nthreads=0, nsamples=1):
        """compute_distance, negative inside (by nsamples rays, odd, a majority vote)."""
        q, shape = self._points(query_points)
        d = self._scene.signed_distance(q, votes=nsamples)
        return self._answer(d.astype(np.float32).reshape(shape), query_points)

    def compute_occupancy(self, query_points, nthreads=0, nsamples=1):
        """1.0 for each (..., 3) point inside the closed surfaces, else 0.0
        (by nsamples rays, odd, a majority vote): float32."""
        q, shape = self._points(query_points)
        inside = self._scene.contains(q, votes=nsamples)
        return self._answer(inside.astype(np.float32).reshape(shape), query_points)

    @staticmethod
    def create_rays_pinhole(*args, **kwargs):
        """(height_px, width_px, 6) float32 rays of a pinhole camera, Open3D's
        two forms: (intrinsic_matrix, extrinsic_matrix, width_px, height_px)
        or (fov_deg, center, eye, up, width_px, height_px)."""
        from raytrace.cast.cameras import create_rays_from_matrices, create_rays_pinhole
        by_fov = ("fov_deg", "center", "eye", "up", "width_px", "height_px")
        by_matrix = ("intrinsic_matrix", "extrinsic_matrix", "width_px", "height_px")
        names = by_fov if len(args) + len(kwargs) == 6 else by_matrix
        if len(args) > len(names):
            raise RaytraceError(f"create_rays_pinhole: takes {names}, got {len(args)} arguments")
        given = dict(zip(names, args))
        for k, a in kwargs.items():
            if k not in names or k in given:
                raise RaytraceError(f"create_rays_pinhole: unexpected or repeated argument {k!r} "
                                    f"(takes {', '.join(names)})")
            given[k] = a
        missing = [k for k in names if k not in given]
        if missing:
            raise RaytraceError(f"create_rays_pinhole: missing {', '.join(missing)}")
        values = [_array(given[k]) if _is_tensor(given[k]) else given[k] for k in names]
        make = create_rays_pinhole if names is by_fov else create_rays_from_matrices
        rays = make(*values).astype(np.float32)
        like = next((given[k] for k in names if _is_tensor(given[k])), None)
        return _answer(rays, like)

    def __repr__(self):
        return f"RaycastingScene({len(self._scene._objects)} geometries)"


def _dtype(key):
    """The dtype of an answer's array, Open3D's."""
    return np.uint32 if key.endswith("_ids") else np.float32
