"""Casting your own rays against a mesh or a scene: the renderer's buffers,
structures and batch kernels (kernels/cast.py), behind validated inputs.

Distances are parametric: a hit is at ``origin + t * direction``, so t is
in units of the direction's length (directions need not be unit length).
Only hits with 0 < t < t_max count.
"""
import numpy as np

from .errors import RaytraceError
from .io.mesh import MAX_COORD, bad_coordinate_rows, check_mesh_arrays
from .scene import Mesh, Scene

class RayHits:
    """Closest hits of n rays.  Each field is an (n,) array, reachable as an
    attribute or by name (``hits.t``, ``hits["t"]``):

    t          distance along the ray, in units of its direction's length (inf: miss)
    prim_id    the face hit, as an index into the faces array given (for a Scene:
               into the faces of mesh ``object_id``; 0 for a sphere or plane); -1: miss
    u, v       barycentric weights of the face's second and third vertices:
               hit point = (1 - u - v) * a + u * b + v * c (NaN: miss, sphere, plane)
    object_id  index of the object hit in scene.objects (0 for a mesh target); -1: miss

    ``hit`` is the boolean mask of rays that hit; ``stats`` the counters
    (rays' primitive and box tests) under the renderer's names.
    """
    FIELDS = ("t", "prim_id", "u", "v", "object_id")

    def __init__(self, t, prim_id, u, v, object_id, stats):
        self.t, self.prim_id, self.u, self.v, self.object_id = t, prim_id, u, v, object_id
        self.stats = stats

    def __getitem__(self, name):
        if name not in self.FIELDS:
            raise KeyError(f"{name!r} (fields: {', '.join(self.FIELDS)})")
        return getattr(self, name)

    def keys(self):
        return self.FIELDS

    def __len__(self):
        return len(self.t)

    @property
    def hit(self):
        return self.prim_id >= 0

    def __repr__(self):
        return f"RayHits({len(self)} rays, {int(self.hit.sum())} hits)"


def _target_scene(target):
    """A Scene for any accepted target; raises RaytraceError otherwise."""
    if isinstance(target, Scene):
        return target
    if hasattr(target, "vertices") and hasattr(target, "faces"):  # trimesh.Trimesh, Mesh
        vertices, faces = target.vertices, target.faces
    elif isinstance(target, (tuple, list)) and len(target) == 2:
        vertices, faces = target
    else:
        raise RaytraceError("target must be a (vertices, faces) pair, a mesh with .vertices and "
                            f".faces (such as a trimesh.Trimesh), or a Scene; got {type(target).__name__}")
    v, f = check_mesh_arrays("target", vertices, faces)
    return Scene(name="rays", camera=None, objects=[Mesh(v, f, name="target")])


def _as_rows(name, a):
    """(n, 3) float64 C-contiguous array of finite values, or (3,) as one row."""
    if np.iscomplexobj(a):
        raise RaytraceError(f"{name}: complex numbers are not coordinates")
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if arr.ndim == 1 and arr.shape[0] == 3:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise RaytraceError(f"{name}: expected shape (n, 3), got {arr.shape}")
    bad = bad_coordinate_rows(arr)
    if bad is not None and bad[0] == "nonfinite":
        raise RaytraceError(f"{name}[{bad[1]}]: NaN or infinite value ({bad[2]} such rows)")
    if bad is not None:
        raise RaytraceError(f"{name}[{bad[1]}]: a value beyond {MAX_COORD:g} "
                            f"(products of such values overflow; {bad[2]} such rows)")
    return np.ascontiguousarray(arr)


def _rays(origins, directions, t_max, t_max_required):
    o = _as_rows("origins", origins)
    d = _as_rows("directions", directions)
    if len(o) == 1 and len(d) > 1:     # one origin for every direction
        o = np.ascontiguousarray(np.broadcast_to(o, d.shape))
    if len(o) != len(d):
        raise RaytraceError(f"origins and directions differ in length ({len(o)} and {len(d)})")
    zero = (d[:, 0] == 0.0) & (d[:, 1] == 0.0) & (d[:, 2] == 0.0)  # finite, checked above
    if zero.any():
        raise RaytraceError(f"directions[{int(np.argmax(zero))}]: zero vector (a ray needs a direction)")
    n = len(d)
    if t_max is None:
        if t_max_required:
            raise RaytraceError("t_max: required (the distance up to which a ray is blocked)")
        tm = np.full(n, np.inf)
    else:
        try:
            tm = np.asarray(t_max, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise RaytraceError(f"t_max: not convertible to float64 ({exc})") from None
        if tm.ndim == 0:
            tm = np.full(n, float(tm))
        if tm.shape != (n,):
            raise RaytraceError(f"t_max: expected a number or shape ({n},), got shape {tm.shape}")
        bad = ~(tm > 0)   # also catches NaN
        if bad.any():
            raise RaytraceError(f"t_max[{int(np.argmax(bad))}]: must be positive (inf allowed), "
                                f"got {tm[np.argmax(bad)]}")
        tm = np.ascontiguousarray(tm)
    return o, d, tm


def _prepare(target, accel):
    from .structures import build_structure, get
    get(accel)
    scene = _target_scene(target)
    from .flatten import flatten
    geo, obj_ranges, _, sources = flatten(scene, with_sources=True)
    acc, _ = build_structure(accel, geo, obj_ranges)
    return geo, acc, sources


def cast_rays(target, origins, directions, accel="bvh", t_max=None):
    """Closest hit of each ray (origins[i], directions[i]) with 0 < t < t_max.

    target: a (vertices (n, 3), faces (m, 3)) pair, anything with
    ``.vertices`` and ``.faces`` (a trimesh.Trimesh), or a Scene.
    origins, directions: (n, 3) arrays (one (3,) origin is used for every
    direction); directions need not be unit length.  t_max: a number or an
    (n,) array, positive; default inf.  accel: none, bvol, bvh or grid (all
    give the same hits).  Returns a RayHits.
    """
    geo, acc, (prim_object, prim_index) = _prepare(target, accel)
    o, d, tm = _rays(origins, directions, t_max, t_max_required=False)
    n = len(d)
    from .raycast import closest
    (t, prim, u, v), cnt = closest(geo, acc, o, d, tm)
    hit = prim >= 0
    tri = hit & (prim < geo.tri_v0.shape[0])
    safe = np.where(hit, prim, 0)
    return RayHits(
        t=t,
        prim_id=np.where(hit, prim_index[safe] if len(prim_index) else 0, -1),
        u=np.where(tri, u, np.nan), v=np.where(tri, v, np.nan),
        object_id=np.where(hit, prim_object[safe] if len(prim_object) else 0, -1),
        stats=_counters(cnt, n),
    )


def occluded(target, origins, directions, t_max, accel="bvh"):
    """Whether anything blocks each ray (origins[i], directions[i]) with
    0 < t < t_max[i]: a boolean (n,) array.  For a shadow ray, pass the
    unnormalised direction to the light and t_max = 1.  Arguments as for
    cast_rays; t_max is required (inf: anywhere along the ray)."""
    geo, acc, _ = _prepare(target, accel)
    o, d, tm = _rays(origins, directions, t_max, t_max_required=True)
    from .raycast import any_hit
    return any_hit(geo, acc, o, d, tm)[0]


def _counters(cnt, n):
    from .stats import counters_from_rows
    c = counters_from_rows(cnt[None, :])
    return {"rays": n, "prim_tests": c["prim_tests"], "prim_hits": c["prim_hits"],
            "box_tests": c["box_tests"], "nodes_visited": c["nodes_visited"],
            "cells_visited": c["cells_visited"]}
