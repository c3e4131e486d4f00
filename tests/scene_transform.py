"""Moving a whole scene: p -> scale * p + shift for every position, and
every length (sphere radius, light size, checker square) times scale, so
the picture is the same one in different units or far from the origin."""
import dataclasses

import numpy as np

from raytrace.scene.model import Mesh, Sphere


def transform_scene(scene, scale=1.0, shift=0.0):
    s = float(scale)
    t = np.broadcast_to(np.asarray(shift, dtype=float), (3,))

    def pos(p):
        return tuple(float(x) for x in np.asarray(p, dtype=float) * s + t)

    materials = {}

    def mat(m):   # materials are shared between objects: scale each once
        if id(m) not in materials:
            materials[id(m)] = dataclasses.replace(m, checker=m.checker * s)
        return materials[id(m)]

    objects = []
    for o in scene.objects:
        if isinstance(o, Mesh):
            o = dataclasses.replace(o, vertices=np.asarray(o.vertices, dtype=float) * s + t)
        elif isinstance(o, Sphere):
            o = dataclasses.replace(o, center=pos(o.center), radius=o.radius * s)
        else:
            o = dataclasses.replace(o, point=pos(o.point))
        objects.append(dataclasses.replace(o, material=mat(o.material)))
    lights = [dataclasses.replace(L, position=pos(L.position),
                                  size=(L.size * s if np.ndim(L.size) == 0
                                        else tuple(float(x) * s for x in L.size)))
              for L in scene.lights]
    camera = dataclasses.replace(scene.camera, eye=pos(scene.camera.eye),
                                 look_at=pos(scene.camera.look_at))
    return dataclasses.replace(scene, objects=objects, lights=lights, camera=camera)
