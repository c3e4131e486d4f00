"""Scene description: plain Python data, no kernels, no Numba.

Coordinates are y-up, right-handed.  Everything a scene file or a built-in
scene can say lives here; ``flatten`` turns it into kernel buffers.
"""
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Material:
    color: tuple = (0.8, 0.8, 0.8)   # linear RGB albedo
    ambient: float = 0.1
    diffuse: float = 0.8
    specular: float = 0.3
    shininess: float = 32.0
    checker: float = 0.0             # >0: checkerboard of this square size (planes)
    reflect: float = 0.0             # mirror weight, 0..1
    transmit: float = 0.0            # glass weight, 0..1 (reflect + transmit <= 1)
    ior: float = 1.5                 # index of refraction, for transmit > 0
    # Linear RGB radiance emitted from the front face (a triangle's winding,
    # a sphere's outside); lights the scene only under the path tracer.
    emission: tuple = (0.0, 0.0, 0.0)
    # Under the path tracer: the weight, 0..1, of a normalised Phong lobe of
    # exponent ``shininess`` beside the diffuse one (kernels/glossy.py).
    glossy: float = 0.0
    # (h, w, 3) linear RGB image multiplying ``color`` on meshes with
    # texture coordinates (an OBJ's map_Kd, a glTF baseColorTexture).
    texture: np.ndarray = field(default=None, compare=False, repr=False)

    def bounces(self):
        """Whether rays leave this material as reflected or refracted rays."""
        return self.reflect > 0.0 or self.transmit > 0.0


@dataclass
class Mesh:
    vertices: np.ndarray             # (n, 3)
    faces: np.ndarray                # (m, 3) indices into vertices
    material: Material = field(default_factory=Material)
    normals: np.ndarray = None       # (n, 3) per-vertex shading normals, or None (flat)
    name: str = "mesh"
    colors: np.ndarray = None        # (n, 3) linear RGB per vertex, multiplying the material's
    uv: np.ndarray = None            # (n, 2) texture coordinates, (0, 0) the image's lower left

    def __repr__(self):              # not the arrays: a notebook would print them all
        return f"Mesh({self.name!r}: {len(self.vertices):,} vertices, {len(self.faces):,} triangles)"


@dataclass
class Sphere:
    center: tuple
    radius: float
    material: Material = field(default_factory=Material)


@dataclass
class Plane:
    point: tuple
    normal: tuple
    material: Material = field(default_factory=Material)


@dataclass
class Light:
    """A point light; with ``size`` > 0 also a square area light of that edge
    length centred on ``position``, facing ``direction`` (used by soft
    shadows); ``size`` = (a, b) makes it an a-by-b rectangle whose first
    edge runs along cross(direction, (1, 0, 0)) -- the z axis for a light
    facing down -- or cross(direction, (0, 0, 1)) if it faces nearly along x."""
    position: tuple
    color: tuple = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    size: float = 0.0                # or (a, b): a rectangle
    direction: tuple = (0.0, -1.0, 0.0)
    samples: int = 0                 # 0: the render's --light-samples
    # A scene file's "file: lights[i]", for error messages; not part of the light.
    where: str = field(default=None, compare=False)


@dataclass
class Camera:
    eye: tuple
    look_at: tuple
    up: tuple = (0.0, 1.0, 0.0)
    fov: float = 60.0                # vertical field of view, degrees
    width: int = 640
    height: int = 480


@dataclass
class Scene:
    name: str
    camera: Camera
    objects: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    background: tuple = (0.55, 0.7, 0.9)
    # A scene file's [animation] table (raytrace.scene.animation.Animation), or
    # None; typed loosely so this module imports nothing more.
    animation: object = None
    # The scene file's ``integrator`` ("whitted" or "path"), or None: the
    # render's option, else whitted.
    integrator: str = None

    def __repr__(self):              # one line: a notebook shows it
        return scene_repr(self)


def scene_repr(scene):
    kinds = {}
    triangles = 0
    for o in scene.objects:
        name = {Mesh: "mesh", Sphere: "sphere", Plane: "plane"}.get(type(o), type(o).__name__)
        kinds[name] = kinds.get(name, 0) + 1
        if isinstance(o, Mesh):
            triangles += len(o.faces)
    objects = ", ".join(f"{n} {k if n == 1 else k + ('es' if k == 'mesh' else 's')}"
                        for k, n in kinds.items()) or "no objects"
    if triangles:
        objects += f" ({triangles:,} triangles)"
    cam = scene.camera
    size = f"{cam.width}x{cam.height}" if hasattr(cam, "width") else "no camera"
    lights = len(scene.lights)
    return (f"Scene({scene.name!r}: {objects}; {lights} light{'s' if lights != 1 else ''}; "
            f"camera {size})")

