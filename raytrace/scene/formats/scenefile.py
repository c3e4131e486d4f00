"""TOML scene files (README, "Scene files") to a Scene.

Parsed with the standard library's tomllib (Python 3.11+; the tomli
backport is used on 3.10 if installed).  Every key is checked: an unknown
key or a wrong type is an error naming the file and the key.
"""
from dataclasses import replace
from pathlib import Path

import numpy as np

from raytrace.errors import RaytraceError, warn
from raytrace.options import BY_NAME, CREASE, DETAIL, FOV_RANGE
from raytrace.scene.animation import MAX_FRAMES, Animation, Key, key_values, view_problem
from raytrace.scene.formats.fields import Fields
from raytrace.scene.formats.mesh import MAX_COORD, check_readable
from raytrace.scene.model import Camera, Light, Material, Plane, Scene, Sphere

TOP_KEYS = ("name", "description", "background", "camera", "materials", "lights", "objects",
            "animation", "integrator")
CAMERA_KEYS = ("position", "look_at", "up", "fov", "width", "height")
ANIMATION_KEYS = ("frames", "keys")
KEY_KEYS = ("frame", "position", "look_at", "fov")
MATERIAL_KEYS = ("color", "ambient", "diffuse", "specular", "shininess", "checker", "reflect",
                 "transmit", "ior", "emission", "glossy")
IOR_RANGE = (1.0, 10.0)   # air to beyond diamond (2.42); below 1 is no material in air
LIGHT_KEYS = ("type", "position", "color", "intensity", "size", "direction", "samples")
AREA_ONLY = ("size", "direction", "samples")
PLACEMENT = ("translate", "rotate", "scale")
OBJECT_KEYS = {
    "mesh": ("type", "file", "material", "smooth", "crease", *PLACEMENT),
    "teapot": ("type", "detail", "material", *PLACEMENT),
    "sphere": ("type", "center", "radius", "material"),
    "plane": ("type", "point", "normal", "material"),
    "quad": ("type", "vertices", "material"),
}


def _toml():
    try:
        import tomllib
    except ImportError:  # Python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            raise RaytraceError("scene files need Python 3.11 or newer "
                                "(or `pip install tomli` on 3.10)") from None
    return tomllib


def parse_toml(path):
    """The file's top-level table, or a RaytraceError naming it."""
    tomllib = _toml()
    check_readable(path)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RaytraceError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    text = text.removeprefix("\ufeff")      # a byte-order mark, as some editors write
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RaytraceError(f"{path}: invalid TOML: {exc}") from None
    except ValueError as exc:   # an integer past Python's 4300-digit limit for reading one
        raise RaytraceError(f"{path}: a number too long to read "
                            f"({str(exc).split(';')[0]})") from None
    except RecursionError:
        raise RaytraceError(f"{path}: nested too deeply to be a scene file") from None


def teapot_details(path):
    """The detail each of the file's teapots asks for, as written (not yet
    checked): load.load_kernels loads the big ones' kernels ahead, as
    compile time.  () for a file that cannot be read; reading it for the
    scene then names the problem."""
    try:
        objects = parse_toml(path).get("objects", [])
    except RaytraceError:
        return ()
    if not isinstance(objects, list):
        return ()
    return tuple(o.get("detail", DETAIL.default) for o in objects
                 if isinstance(o, dict) and o.get("type") == "teapot")


def written_integrator(path):
    """The file's ``integrator`` as written (not yet checked), or None: the
    command's first-run notice reads it before loading, which names any
    problem.  RaytraceError for a file that is not TOML."""
    return parse_toml(path).get("integrator")


def read_scene_file(path):
    """A Scene from a TOML scene file; mesh paths are relative to it."""
    try:
        return _read_scene_file(Path(path))
    except RecursionError:       # a value nested past Python's stack, met while checking it
        raise RaytraceError(f"{path}: nested too deeply to be a scene file") from None


def _read_scene_file(path):
    top = Fields(path, "", parse_toml(path), TOP_KEYS)
    if not top.has("camera"):
        top.fail(None, "missing table [camera]")
    materials = _materials(path, top)
    default_material = Material()

    def material(f):
        name = f.string("material")
        if name is None:
            return default_material
        if name not in materials:
            known = ", ".join(materials) or "none"
            f.fail("material", f"no material named {name!r} (defined: {known})")
        return materials[name]

    # A mesh file of several materials gives one object per material.
    objects = [obj for i, t in enumerate(top.tables("objects")) for obj in _objects(path, i, t, material)]
    scene = Scene(
        name=_scene_name(top, path),
        camera=_camera(path, top.table["camera"]),
        objects=objects,
        lights=[_light(path, i, t) for i, t in enumerate(top.tables("lights"))],
    )
    top.string("description")
    if top.has("background"):
        scene.background = top.color("background")
    scene.integrator = top.string("integrator", default=None,
                                  choices=BY_NAME["integrator"].choice_list())
    if top.has("animation"):
        scene.animation = _animation(path, top.table["animation"], scene.camera)
    return scene


# A scene's name names its outputs (NAME.png, NAME.gif, NAME.compare.png)
# in the working directory: room left for the longest suffix in 255 bytes.
NAME_BYTES = 200


def _scene_name(top, path):
    """The file's ``name``, which must be a plain file name: a downloaded
    scene must not choose where its image goes (``../x``, ``/tmp/x``)."""
    name = top.string("name", default=None)
    if name is None:
        return path.stem
    if name in ("", ".", ".."):
        top.fail("name", f"must be a plain file name, got {name!r}")
    if "/" in name or "\\" in name:
        top.fail("name", f"must be a plain file name, without a directory, got {name!r}")
    if not name.isprintable():
        top.fail("name", f"must be printable, without control characters, got {name!r}")
    if len(name.encode()) > NAME_BYTES:
        top.fail("name", f"longer than {NAME_BYTES} bytes")
    return name


def _camera(path, table):
    f = Fields(path, "camera", table, CAMERA_KEYS)
    cam = Camera(eye=f.vec3("position", required=True), look_at=f.vec3("look_at", required=True),
                 up=f.vec3("up", default=(0.0, 1.0, 0.0), nonzero=True),
                 fov=f.number("fov", default=60.0, lo=FOV_RANGE[0], hi=FOV_RANGE[1]),
                 width=f.integer("width", default=640, lo=BY_NAME["width"].lo, hi=BY_NAME["width"].hi),
                 height=f.integer("height", default=480, lo=BY_NAME["height"].lo,
                                  hi=BY_NAME["height"].hi))
    problem = view_problem(cam.eye, cam.look_at, cam.up)
    if problem:
        f.fail(*problem)
    if not FOV_RANGE[0] < cam.fov < FOV_RANGE[1]:
        f.fail("fov", f"must be between {FOV_RANGE[0]:g} and {FOV_RANGE[1]:g} degrees (exclusive), "
                      f"got {cam.fov:g}")
    if cam.eye == cam.look_at:
        f.fail("look_at", "must differ from the camera position")
    return cam


def _animation(path, table, camera):
    """An [animation] table: frames, and keys in increasing frame order,
    each a valid camera with the [camera]'s up -- and so is every frame
    between them, where position and look_at move linearly."""
    f = Fields(path, "animation", table, ANIMATION_KEYS)
    frames = f.integer("frames", required=True, lo=1, hi=MAX_FRAMES)
    tables = f.tables("keys")
    if not tables:
        f.fail(None, "missing [[animation.keys]] (at least one: frame, position, look_at)")
    keys = []
    for i, t in enumerate(tables):
        k = Fields(path, f"animation.keys[{i}]", t, KEY_KEYS)
        frame = k.integer("frame", required=True, lo=0, hi=frames - 1)
        if keys and frame <= keys[-1].frame:
            k.fail("frame", f"keys must be in strictly increasing frame order, got {frame} "
                            f"after {keys[-1].frame}")
        key = Key(frame=frame, position=k.vec3("position", required=True),
                  look_at=k.vec3("look_at", required=True), fov=k.number("fov"))
        if key.fov is not None and not FOV_RANGE[0] < key.fov < FOV_RANGE[1]:
            k.fail("fov", f"must be between {FOV_RANGE[0]:g} and {FOV_RANGE[1]:g} degrees "
                          f"(exclusive), got {key.fov:g}")
        problem = view_problem(key.position, key.look_at, camera.up)
        if problem:
            k.fail(*(problem if problem[0] == "look_at" else
                     ("look_at", "view direction (position to look_at) parallel to [camera] up")))
        keys.append(key)
    animation = Animation(frames=frames, keys=tuple(keys))
    # Between two valid keys the eye may still cross look_at, or look along up.
    for n, (eye, look_at, _) in enumerate(key_values(animation, camera.fov)):
        problem = view_problem(eye, look_at, camera.up)
        if problem:
            i = sum(key.frame < n for key in keys)
            f.fail("keys", f"frame {n}, between keys[{i - 1}] and keys[{i}]: "
                           + ("position meets look_at" if problem[0] == "look_at"
                              else "view direction parallel to [camera] up"))
    return animation


def _materials(path, top):
    table = top.table.get("materials", {})
    if not isinstance(table, dict):
        top.fail("materials", "expected a table of named materials ([materials.NAME])")
    out = {}
    for name, t in table.items():
        f = Fields(path, f"materials.{name}", t, MATERIAL_KEYS)
        d = Material()
        out[name] = Material(color=f.color("color", default=d.color),
                             ambient=f.number("ambient", default=d.ambient, lo=0.0),
                             diffuse=f.number("diffuse", default=d.diffuse, lo=0.0),
                             specular=f.number("specular", default=d.specular, lo=0.0),
                             shininess=f.number("shininess", default=d.shininess, lo=0.0),
                             checker=f.number("checker", default=d.checker, lo=0.0),
                             reflect=f.number("reflect", default=d.reflect, lo=0.0, hi=1.0),
                             transmit=f.number("transmit", default=d.transmit, lo=0.0, hi=1.0),
                             ior=f.number("ior", default=d.ior, lo=IOR_RANGE[0], hi=IOR_RANGE[1]),
                             emission=f.color("emission", default=d.emission),
                             glossy=f.number("glossy", default=d.glossy, lo=0.0, hi=1.0))
        if out[name].reflect + out[name].transmit > 1.0:
            f.fail("transmit", f"reflect + transmit must be at most 1 (the light a surface "
                               f"returns), got {out[name].reflect:g} + {out[name].transmit:g}")
    return out


def _light(path, i, table):
    f = Fields(path, f"lights[{i}]", table, LIGHT_KEYS)
    kind = f.string("type", default="point", choices=("point", "area"))
    light = Light(position=f.vec3("position", required=True),
                  color=f.color("color", default=(1.0, 1.0, 1.0)),
                  intensity=f.number("intensity", default=1.0, lo=0.0),
                  where=f"{path}: lights[{i}]")
    if kind == "point":
        for key in AREA_ONLY:
            if f.has(key):
                f.fail(key, "only area lights (type = \"area\") have this key")
        return light
    size = f.table.get("size")
    if size is None:
        f.fail(None, "missing key 'size' (an area light's edge length, or [width, height])")
    if isinstance(size, list):
        light.size = f.numbers("size", 2)
        for k, s in enumerate(light.size):
            f.check_number(f"size[{k}]", s, positive=True)
    else:
        light.size = f.check_number("size", size, positive=True)
    light.direction = f.vec3("direction", default=(0.0, -1.0, 0.0), nonzero=True)
    light.samples = f.integer("samples", default=0, lo=BY_NAME["light_samples"].lo,
                              hi=BY_NAME["light_samples"].hi)
    return light


def _objects(path, i, table, material):
    """The scene objects of objects[i]: one, or a mesh file's parts."""
    where = f"objects[{i}]"
    # The type decides which keys are allowed, so it is checked first.
    kind = Fields(path, where, {"type": table.get("type")}, ("type",)).string(
        "type", choices=tuple(OBJECT_KEYS)) if "type" in table else None
    if kind is None:
        Fields(path, where, {}, ()).fail(None, f"missing key 'type' (one of: {', '.join(OBJECT_KEYS)})")
    f = Fields(path, where, table, OBJECT_KEYS[kind])
    if kind == "sphere":
        sphere = Sphere(center=f.vec3("center", required=True),
                        radius=f.number("radius", required=True, positive=True),
                        material=material(f))
        if max(map(abs, sphere.center)) + sphere.radius > MAX_COORD:
            f.fail("radius", f"the sphere reaches beyond {MAX_COORD:g}")
        return [sphere]
    if kind == "plane":
        return [Plane(point=f.vec3("point", default=(0.0, 0.0, 0.0)),
                      normal=f.vec3("normal", default=(0.0, 1.0, 0.0), nonzero=True),
                      material=material(f))]
    if kind == "quad":
        return [_quad(f, material(f), i)]
    if kind == "teapot":
        from raytrace.scene.builtin import teapot_mesh
        meshes = [teapot_mesh(f.integer("detail", default=DETAIL.default, lo=DETAIL.lo,
                                        hi=DETAIL.hi), material(f))]
    else:
        meshes = _mesh_file(path, f, material)
    place = dict(translate=f.vec3("translate", default=(0.0, 0.0, 0.0)),
                 rotate=f.vec3("rotate", default=(0.0, 0.0, 0.0)),
                 scale=f.scale3("scale"))
    if place != dict(translate=(0.0,) * 3, rotate=(0.0,) * 3, scale=(1.0,) * 3):
        from raytrace.scene.transform import transform_mesh
        for mesh in meshes:
            with np.errstate(over="ignore", invalid="ignore"):
                mesh.vertices, mesh.normals = transform_mesh(mesh.vertices, mesh.normals, **place)
            if not (np.abs(mesh.vertices) <= MAX_COORD).all():
                f.fail("scale", f"translate, rotate and scale put a vertex beyond {MAX_COORD:g}")
    return meshes


def _quad(f, material, i):
    """A quad's four corners, in order around it, as a flat two-triangle
    Mesh; the winding (right-handed) sets its front, where an emission
    leaves it."""
    from raytrace.scene.model import Mesh
    corners = f.table.get("vertices")
    if not isinstance(corners, list) or len(corners) != 4 or not all(
            isinstance(c, list) and len(c) == 3 for c in corners):
        f.fail("vertices", "expected 4 corners, each [x, y, z]")
    v = np.array([[f.check_number(f"vertices[{k}][{a}]", x) for a, x in enumerate(c)]
                  for k, c in enumerate(corners)])
    if not (np.abs(v) <= MAX_COORD).all():
        f.fail("vertices", f"a corner beyond {MAX_COORD:g}")
    return Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), material, name=f"quad objects[{i}]")


def _mesh_file(path, f, material):
    """The Meshes of a mesh object's file: its own materials unless the
    object names one, its own normals or smooth ones split at ``crease``
    degrees unless ``smooth = false``."""
    from raytrace.scene.formats.mesh import part_mesh, read_mesh_parts
    file = f.string("file", required=True)
    mesh_path = path.parent / file
    smooth = f.boolean("smooth", default=True)
    crease = f.number("crease", default=CREASE.default, lo=CREASE.lo, hi=CREASE.hi)
    if f.has("crease") and not smooth:
        f.fail("crease", "only smooth meshes (smooth = true) have creases")
    # An object's own material replaces the file's (whose warnings then do
    # not matter).
    own = f.has("material")
    try:
        parts = read_mesh_parts(mesh_path, warn=None if own else warn, base=material(f))
    except RaytraceError as exc:
        f.fail("file", str(exc))
    return [part_mesh(replace(p, material=None) if own else p, material(f), crease, not smooth,
                      str(mesh_path)) for p in parts]
