"""One entry point for every kind of scene: a built-in name, a mesh file or
a TOML scene file."""
import math
from numbers import Integral, Real
from pathlib import Path

import numpy as np

from raytrace.errors import RaytraceError, warn
from raytrace.options import DETAIL
from raytrace.scene.formats.mesh import MESH_EXTENSIONS, is_mesh_path

SCENE_EXTENSIONS = (".toml",)
MESH_ONLY = ("view", "azimuth", "elevation", "up", "crease", "flat")


def scene_kind(name):
    """"builtin", "mesh", "toml", or None for a name that is none of them."""
    from raytrace.scene.builtin import BUILTIN
    name = str(name)
    if name in BUILTIN:
        return "builtin"
    if is_mesh_path(name):
        return "mesh"
    if Path(name).suffix.lower() in SCENE_EXTENSIONS:
        return "toml"
    return None


def unknown_scene_message(name):
    from raytrace.scene.builtin import BUILTIN
    from raytrace.scene.examples import example_names
    what = ("empty scene name" if str(name) == "" else
            f"{name}: is a directory, not a scene or mesh file" if Path(str(name)).is_dir()
            else f"unknown scene {str(name)!r}")
    return (f"{what} (scenes: {', '.join(sorted([*BUILTIN, *example_names()]))}; "
            f"or a .toml scene file, or a mesh file: {', '.join(MESH_EXTENSIONS)})")


def load_scene(name_or_path, *, detail=None, view=None, azimuth=None, elevation=None, up=None,
               crease=None, flat=None, fov=None, width=None, height=None):
    """A Scene from a built-in name ("teapot"), a mesh file or a .toml file.

    detail: teapot tessellation (built-in teapot only).
    view, azimuth, elevation, up: how a mesh file is framed (mesh files
    only): a named view (front, back, left, right, top, bottom, iso), or an
    azimuth/elevation pair in degrees, about the up axis (x, y, z, -x, -y,
    -z; default y).
    crease, flat: a mesh file's shading (mesh files only): its own vertex
    normals if it has them, else normals smooth across edges up to
    ``crease`` degrees (default 35) and split at sharper ones; flat=True
    shades each triangle flat.  A file's materials and what cannot be
    shown of them are told as RaytraceWarnings.
    fov, width, height: override the camera's field of view (degrees) and
    image size; a mesh file's camera is framed for them.
    """
    if not isinstance(name_or_path, (str, Path)):
        raise RaytraceError(f"scene: expected a name or a path, got {type(name_or_path).__name__}")
    from raytrace.scene.examples import resolve
    name_or_path = resolve(name_or_path)
    kind = scene_kind(name_or_path)
    if kind is None:
        raise RaytraceError(unknown_scene_message(name_or_path))
    _check_view_numbers(width=width, height=height, fov=fov, azimuth=azimuth, elevation=elevation)
    # NumPy scalars are numbers too; Python's from here on.
    width, height = (None if v is None else int(v) for v in (width, height))
    fov, azimuth, elevation = (None if v is None else float(v) for v in (fov, azimuth, elevation))
    mesh_opts = dict(view=view, azimuth=azimuth, elevation=elevation, up=up, crease=crease,
                     flat=flat)
    given = [k for k, v in mesh_opts.items() if v is not None]
    if given and kind != "mesh":
        raise RaytraceError(f"{given[0]} applies to mesh files only ({', '.join(MESH_EXTENSIONS)})")
    if detail is not None:
        if not (kind == "builtin" and str(name_or_path) == "teapot"):
            raise RaytraceError("detail applies to the teapot scene only")
        if not _detail_ok(detail):
            raise RaytraceError(f"detail must be an integer from {DETAIL.lo} to {DETAIL.hi}, "
                                f"got {detail!r}")
        detail = int(detail)

    crease = check_shading(crease, flat)

    if kind == "mesh":
        from raytrace.scene.formats.mesh import part_mesh, read_mesh_parts
        from raytrace.scene.framing import MESH_MATERIAL, mesh_scene
        from raytrace.scene.model import Material
        path = Path(name_or_path)
        parts = read_mesh_parts(path, warn=warn, base=Material(**MESH_MATERIAL))
        if not any(_has_area(p) for p in parts):
            raise RaytraceError(f"{path}: no non-degenerate triangles (every face has no area)")
        meshes = [part_mesh(p, Material(**MESH_MATERIAL), crease, flat, str(path)) for p in parts]
        extra = {k: v for k, v in dict(fov=fov, width=width, height=height).items() if v is not None}
        # One part (most files): its vertices frame the view as they are,
        # not copied.
        framed = parts[0].vertices if len(parts) == 1 else np.concatenate([p.vertices
                                                                           for p in parts])
        return mesh_scene(framed, None, name=path.stem,
                          up=up or "y", view=view, azimuth=azimuth, elevation=elevation,
                          source=path, meshes=meshes, **extra)
    if kind == "builtin":
        from raytrace.scene.builtin import BUILTIN
        factory = BUILTIN[str(name_or_path)][0]
        scene = factory(detail=detail) if detail is not None else factory()
    else:
        from raytrace.scene.formats.scenefile import read_scene_file
        scene = read_scene_file(name_or_path)
    if fov is not None:
        scene.camera.fov = fov
    if width is not None:
        scene.camera.width = width
    if height is not None:
        scene.camera.height = height
    return scene


def _detail_ok(detail):
    return (not isinstance(detail, bool) and isinstance(detail, Integral)
            and DETAIL.lo <= detail <= DETAIL.hi)


def load_kernels(name_or_path, detail=None):
    """Seconds spent loading (or compiling) the kernels that load_scene
    will run for this scene, so that loading's time is not compile time
    (the command's statistics); 0.0 if it runs none.  Only a big teapot
    has any, built in or in a scene file: its tessellation's
    (scenes/teapot.py)."""
    from raytrace.scene.examples import resolve
    name_or_path = resolve(name_or_path)
    if scene_kind(name_or_path) == "toml":
        from raytrace.scene.formats.scenefile import teapot_details
        detail = max((d for d in teapot_details(name_or_path) if _detail_ok(d)), default=None)
    elif str(name_or_path) != "teapot":
        return 0.0
    if not _detail_ok(detail):
        return 0.0
    from raytrace.scene.teapot import load_kernels
    return load_kernels(detail)


def check_shading(crease, flat):
    """The crease angle to use (the default if None), or a RaytraceError."""
    from raytrace.options import CREASE
    from raytrace.scene.normals import DEFAULT_CREASE
    if flat is not None and not isinstance(flat, bool):
        raise RaytraceError(f"flat must be True or False, got {flat!r}")
    if crease is None:
        return DEFAULT_CREASE
    if flat:
        raise RaytraceError("crease and flat contradict each other (flat shading has no creases)")
    CREASE.check(crease)
    return float(crease)


def _check_view_numbers(**values):
    """load_scene's numeric arguments, each named with the value given."""
    from raytrace.options import BY_NAME, FOV_RANGE
    for name in ("width", "height"):
        if values[name] is not None:
            BY_NAME[name].check(values[name])
    for name, lo, hi in (("fov", *FOV_RANGE), ("azimuth", None, None), ("elevation", -90.0, 90.0)):
        v = values[name]
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v):
            raise RaytraceError(f"{name} must be a finite number, got {v!r}")
        if name == "fov" and not lo < v < hi:
            raise RaytraceError(f"fov must be between {lo:g} and {hi:g} degrees (exclusive), got {v!r}")
        if name == "elevation" and not lo <= v <= hi:
            raise RaytraceError(f"elevation must be between -90 and 90 degrees, got {v!r}")


def _has_area(part, chunk=4096):
    """Whether any face of a MeshPart has an area: a chunk at a time, so a
    good mesh answers from its first faces (flatten tests every face)."""
    from raytrace.scene.flatten import degenerate_mask
    for k in range(0, len(part.faces), chunk):
        f = part.faces[k:k + chunk]
        if not degenerate_mask(*(part.vertices[f[:, c]] for c in range(3))).all():
            return True
    return False
