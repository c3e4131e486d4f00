"""Built-in scenes, named on the command line."""
import numpy as np

from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene, Sphere

GROUND = Material(color=(0.75, 0.75, 0.72), ambient=0.15, diffuse=0.85, specular=0.0,
                  shininess=1.0, checker=1.0)


def teapot_mesh(detail=4, material=None):
    """The teapot as a y-up Mesh, standing on y = 0 (scene files use this too)."""
    from raytrace.scene.teapot import tessellate
    v, f, n = tessellate(detail)
    # Newell's data is z-up; the renderer is y-up: (x, y, z) -> (x, z, -y).
    swap = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)
    return Mesh(v @ swap, f, material or Material(), normals=n @ swap, name="teapot")


def teapot(detail=4):
    """The Utah teapot on a checkered ground, lit by one light.

    detail=4 gives the workshop's ~1k-triangle model (992 after the pole
    triangles are dropped); detail=43 about 118k triangles.
    """
    body = Material(color=(0.80, 0.22, 0.12), ambient=0.12, diffuse=0.8, specular=0.5, shininess=48.0)
    return Scene(
        name="teapot",
        camera=Camera(eye=(2.4, 3.7, 5.6), look_at=(0.2, 1.2, 0.0), fov=60.0),
        objects=[teapot_mesh(detail, body),
                 Plane(point=(0, 0, 0), normal=(0, 1, 0), material=GROUND)],
        lights=[Light(position=(-4.0, 9.0, 5.0), intensity=1.0, size=3.0)],
    )


def spheres():
    """Four spheres of different sizes and colours on a plane."""
    def mat(c):
        return Material(color=c, ambient=0.1, diffuse=0.8, specular=0.6, shininess=64.0)
    return Scene(
        name="spheres",
        camera=Camera(eye=(0.0, 2.6, 8.0), look_at=(0.3, 0.9, 0.0), fov=60.0),
        objects=[
            Sphere((-1.9, 1.0, 0.0), 1.0, mat((0.85, 0.15, 0.12))),
            Sphere((0.5, 0.6, 1.3), 0.6, mat((0.15, 0.7, 0.2))),
            Sphere((1.5, 0.3, 2.6), 0.3, mat((0.15, 0.3, 0.9))),
            Sphere((2.4, 1.4, -1.4), 1.4, mat((0.9, 0.75, 0.15))),
            Plane(point=(0, 0, 0), normal=(0, 1, 0), material=GROUND),
        ],
        lights=[Light(position=(-5.0, 8.0, 6.0), intensity=1.0, size=3.0)],
    )


# name -> (factory, one-line description); the CLI's choices come from here.
BUILTIN = {
    "teapot": (teapot, "Utah teapot (Newell's 32 Bezier patches, ~1k triangles; --detail N) on a plane"),
    "spheres": (spheres, "four spheres of different sizes and colours on a plane"),
}
