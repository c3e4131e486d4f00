"""Shadow rays start RAY_OFFSET times the hit point's magnitude off the
surface: far enough never to re-hit the surface they leave (no shadow
acne), near enough never to skip past nearby geometry (no light leaking
through), at scales 1e-4, 1 and 1e4, each also 1e5 from the origin.

Each scene is built at unit size and moved with transform_scene, so the
expected answer is the same in every case: zero occluded shadow rays for
the acne scenes, all of them occluded for the leak scenes.
"""
import numpy as np
import pytest

from raytrace.renderer.driver import render
from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene, Sphere
from tests.scene_transform import transform_scene
from tests.structures import EVERY_MODE, STRUCTURES
from tests.test_watertight import subdivided_box

CASES = [(scale, shift) for shift in (0.0, 1e5) for scale in (1e-4, 1.0, 1e4)]
SIZE = dict(width=48, height=36)
WHITE = Material(color=(0.9, 0.9, 0.9), ambient=0.1, diffuse=0.9, specular=0.2, shininess=16.0)


def icosphere_mesh():
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=3)          # 1280 flat facets
    return Mesh(np.asarray(m.vertices), np.asarray(m.faces), WHITE)


# Convex or flat surfaces alone: a shadow ray from the lit side can only be
# blocked by the surface it leaves, so every occluded ray is acne.  Point
# lights (hard shadows) only: samples of an area light can lie below a
# point's horizon, and those rays are rightly blocked.
ACNE_SCENES = {
    "sphere": lambda: Scene("sphere", Camera((0.3, 1.0, 3.5), (0, 0, 0), fov=45.0),
                            [Sphere((0, 0, 0), 1.0, WHITE)],
                            lights=[Light((-3, 4, 3)), Light((4, 0.5, 1), intensity=0.5),
                                    Light((0.5, -3, 2), intensity=0.3)]),
    "icosphere": lambda: Scene("icosphere", Camera((0.3, 1.0, 3.5), (0, 0, 0), fov=45.0),
                               [icosphere_mesh()],
                               lights=[Light((-3, 4, 3)), Light((4, 0.5, 1), intensity=0.5)]),
    "plane": lambda: Scene("plane", Camera((0, 1.5, 3), (0, 0, -1), fov=70.0),
                           [Plane((0, 0, 0), (0.1, 1.0, 0.05), WHITE)],
                           lights=[Light((0.5, 3.0, -1.0), size=2.0)]),
}


@pytest.mark.parametrize("accel", STRUCTURES)
@pytest.mark.parametrize("scale, shift", CASES)
@pytest.mark.parametrize("name", list(ACNE_SCENES))
def test_no_shadow_acne(name, scale, shift, accel):
    scene = transform_scene(ACNE_SCENES[name](), scale, shift)
    # Soft shadows for brute force and the default structure (tests/structures.py).
    shadow_modes = ("hard", "soft") if name == "plane" and accel in EVERY_MODE else ("hard",)
    for shadows in shadow_modes:
        r = render(scene, accel=accel, shadows=shadows, light_samples=16, pattern="random", **SIZE)
        c = r.stats["counters"]
        assert c["shading_points"] > 0.2 * 48 * 36 and c["shadow_rays"] > 0
        assert c["occluded_rays"] == 0, \
            f"{c['occluded_rays']} of {c['shadow_rays']} shadow rays hit their own surface"


def slab_scene(kind):
    """Ground at y = 0, and 0.01 above it a slab 1e-4 thick covering
    x, z in [-4, 4]: a closed box, or two separate parallel quads.  The
    camera sits between ground and slab looking down, so it sees only
    ground; the light is above the slab.  Every shadow ray must cross it."""
    lo, hi = 0.01, 0.01 + 1e-4
    if kind == "box":
        v, f = subdivided_box(levels=0)
        v = (v + 1.0) / 2.0 * [8.0, hi - lo, 8.0] + [-4.0, lo, -4.0]
    else:
        quad = np.array([[-4.0, 0, -4.0], [4.0, 0, -4.0], [4.0, 0, 4.0], [-4.0, 0, 4.0]])
        v = np.concatenate([quad + [0, lo, 0], quad + [0, hi, 0]])
        f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    objs = [Mesh(v, f, WHITE), Plane((0, 0, 0), (0, 1, 0), WHITE)]
    return Scene(f"slab {kind}", Camera((0, 0.005, 0), (0, 0, 0.004), fov=60.0), objs,
                 lights=[Light((0.5, 2.0, 0.3), size=1.0)])


@pytest.mark.parametrize("accel", STRUCTURES)
@pytest.mark.parametrize("scale, shift", CASES)
@pytest.mark.parametrize("kind", ["box", "two quads"])
def test_thin_slab_lets_no_light_through(kind, scale, shift, accel):
    scene = transform_scene(slab_scene(kind), scale, shift)
    dark = transform_scene(slab_scene(kind), scale, shift)
    dark.lights = []
    for shadows in ("hard", "soft") if accel in EVERY_MODE else ("hard",):
        r = render(scene, accel=accel, shadows=shadows, light_samples=16, pattern="random", aov=True, **SIZE)
        c = r.stats["counters"]
        n_tris = r.stats["triangles"]
        assert (r.aovs["primid"] == n_tris).all()           # the camera sees only the ground
        assert c["shadow_rays"] == c["shading_points"] * (16 if shadows == "soft" else 1)
        assert c["occluded_rays"] == c["shadow_rays"], \
            f"{c['shadow_rays'] - c['occluded_rays']} shadow rays got through"
        assert np.array_equal(r.linear, render(dark, accel=accel, shadows=shadows, **SIZE).linear)
