"""A scene's kind, as the renderer's compiled kernels see it, and tiny
scenes of each kind.

The shading stages compile once per combination of textures (a mesh's
vertex colours or image) and mirrors or glass; the shadow mode, sizes and
structure do not enter (kernels/waves.py).  A tiny scene of the same kind
compiles the same kernels: ``raytrace warmup``, each Dask worker before its
first tile, and a first render's compile in a second process
(renderer/ahead.py) use it.
"""
import numpy as np


def scene_kind(scene):
    """(textures, mirrors) of a Scene, read from its description as flatten
    and the driver's records will read it: textures where a mesh has vertex
    colours or a textured material, mirrors where a material reflects or
    transmits."""
    from raytrace.scene.model import Mesh
    objects = list(getattr(scene, "objects", None) or ())
    textures = any(isinstance(o, Mesh) and (o.colors is not None
                                            or getattr(o.material, "texture", None) is not None)
                   for o in objects)
    return textures, any(o.material.bounces() for o in objects if hasattr(o, "material"))


def tiny_scene(textures, mirrors):
    """A 4x3 scene of that kind: a quad (with vertex colours, texture
    coordinates and an image if ``textures``), a sphere (a glass mirror if
    ``mirrors``), a checkered plane and an area light."""
    from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene, Sphere
    quad = Mesh(np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], float) + [0, 0.5, 0],
                np.array([[0, 2, 1], [0, 3, 2]]), Material(),
                normals=np.tile([0.0, 1.0, 0.0], (4, 1)))
    if textures:
        quad.colors = np.full((4, 3), 0.5)
        quad.uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
        quad.material.texture = np.full((2, 2, 3), 0.5)
    ball = Sphere((0.0, 1.5, 0.0), 0.5, Material(reflect=0.5, transmit=0.2) if mirrors else Material())
    return Scene("warmup", Camera((0.0, 2.0, 5.0), (0.0, 0.5, 0.0), width=4, height=3),
                 [quad, ball, Plane((0, 0, 0), (0, 1, 0), Material(checker=1.0))],
                 [Light((2.0, 5.0, 2.0), size=1.0)])
