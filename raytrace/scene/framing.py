"""A scene around a bare mesh: a camera that frames it, a ground plane
under it and a light, for ``raytrace model.obj``.

Directions are in the mesh's own frame.  ``up`` is one of the six axis
directions.  The ``front`` view looks at the model from +z for y-up (and
x-up) models and from -y for z-up ones, the usual conventions of those
formats; "right" is cross(up, front), so right is +x for y-up and z-up.
"""
import math

import numpy as np

from raytrace.errors import RaytraceError
from raytrace.kernels.buffers import box_of
from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene
from raytrace.scene.views import DEFAULT_VIEW, UP_AXES, VIEWS

# The model fills the frame but for this margin (1.1: 10% on the tightest
# side), so nothing touches the edge.
MARGIN = 1.1

MESH_MATERIAL = dict(color=(0.72, 0.72, 0.76), ambient=0.12, diffuse=0.8, specular=0.35,
                     shininess=32.0)
GROUND_MATERIAL = dict(color=(0.75, 0.75, 0.72), ambient=0.15, diffuse=0.85, specular=0.0,
                       shininess=1.0)


def axis_frame(up):
    """(up, front, right) unit vectors for an up-axis name such as "-z"."""
    if up not in UP_AXES:
        raise RaytraceError(f"unknown up axis {up!r} (choose from {', '.join(UP_AXES)})")
    k = "xyz".index(up[-1])
    u = np.zeros(3)
    u[k] = -1.0 if up.startswith("-") else 1.0
    # Front: +z for a y-up model, -y for a z-up one (so right is +x in both),
    # +z for an x-up one; a flipped up keeps the same front.
    front = {0: np.array([0.0, 0.0, 1.0]), 1: np.array([0.0, 0.0, 1.0]),
             2: np.array([0.0, -1.0, 0.0])}[k]
    return u, front, np.cross(u, front)


def view_direction(up, azimuth, elevation):
    """(direction from the model to the camera, camera up), both unit."""
    u, f, r = axis_frame(up)
    az, el = math.radians(azimuth), math.radians(elevation)
    horiz = math.cos(az) * f + math.sin(az) * r
    d = math.cos(el) * horiz + math.sin(el) * u
    # d/d(elevation): orthogonal to d and never zero, so a view from
    # straight above still has an up (the model's back at the top).
    cam_up = -math.sin(el) * horiz + math.cos(el) * u
    return d, cam_up


def _tup(a):
    return tuple(float(x) for x in a)


def _nice_checker(radius):
    """A power of ten near half the model's radius: a few squares under the
    model whatever its units."""
    return 10.0 ** round(math.log10(radius / 2))


def mesh_scene(vertices, faces, name="mesh", view=None, azimuth=None, elevation=None,
               up="y", fov=60.0, width=640, height=480, source=None, meshes=None):
    """A Scene showing the mesh whole from ``view`` (a name in VIEWS) or
    from an (azimuth, elevation) pair in degrees (either overrides the
    view's), on a checkered ground at its lowest point along ``up``.
    ``source`` (the file, default ``name``) is what error messages name.
    ``meshes``: the Mesh objects to show (a file's parts, with their own
    materials and normals) in place of one flat grey mesh; ``vertices``
    still frame the view."""
    source = source or name
    if view is not None and view not in VIEWS:
        raise RaytraceError(f"unknown view {view!r} (choose from {', '.join(VIEWS)})")
    az, el = VIEWS[view or DEFAULT_VIEW]
    az = az if azimuth is None else float(azimuth)
    el = el if elevation is None else float(elevation)
    if not (math.isfinite(az) and math.isfinite(el) and -90.0 <= el <= 90.0):
        raise RaytraceError(f"elevation must be between -90 and 90 degrees, got {el}")
    if not 0 < fov < 180:
        raise RaytraceError(f"field of view must be between 0 and 180 degrees, got {fov}")
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = box_of(v, v)
    center = (lo + hi) / 2
    radius = float(np.linalg.norm(hi - lo)) / 2
    if not radius > 0:
        raise RaytraceError(f"{source}: the mesh has no extent (all vertices coincide)")
    u, _, _ = axis_frame(up)
    d, cam_up = view_direction(up, az, el)

    # The nearest camera position (along d, aimed at the box centre) at
    # which every vertex is inside both fields of view, less the margin:
    # vertex p needs dist >= toward(p) + MARGIN * |x(p)| / tan(half fov).
    # Fitting the vertices, not a bounding sphere, keeps a long model seen
    # end-on from shrinking to a speck.
    tan_v = math.tan(math.radians(fov) / 2)
    tan_h = tan_v * width / height
    right = np.cross(-d, cam_up)
    rel = v - center
    toward = rel @ d
    dist = max(float(np.max(toward + MARGIN * np.abs(rel @ right) / tan_h)),
               float(np.max(toward + MARGIN * np.abs(rel @ cam_up) / tan_v)),
               float(np.max(toward)) + 0.05 * radius)   # never inside the model
    eye = center + dist * d
    camera = Camera(eye=_tup(eye), look_at=_tup(center), up=_tup(cam_up), fov=fov,
                    width=width, height=height)

    objects = list(meshes) if meshes else [Mesh(v, faces, Material(**MESH_MATERIAL), name=str(source))]
    ground_h = float((v @ u).min())
    # From below the ground the plane would hide the model: leave it out.
    if float(eye @ u) > ground_h:
        objects.append(Plane(point=_tup(ground_h * u), normal=_tup(u),
                             material=Material(**GROUND_MATERIAL, checker=_nice_checker(radius))))
    # Light above, turned 45 degrees to the camera's left so shading and
    # the shadow show the shape; a square area light a model's radius wide.
    ld, _ = view_direction(up, az - 45.0, 60.0)
    light = Light(position=_tup(center + 4 * radius * ld), size=radius, direction=_tup(-u))
    return Scene(name=name, camera=camera, objects=objects, lights=[light])
