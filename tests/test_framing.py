"""Mesh files get a camera that frames them, a ground under them, a light."""
import numpy as np
import pytest

from raytrace.renderer.driver import camera_buffer
from raytrace.scene.framing import mesh_scene, view_direction
from raytrace.scene.model import Plane
from raytrace.scene.views import UP_AXES, VIEWS

# An asymmetric box-ish cloud: long along x, short along z, off the origin.
RNG = np.random.default_rng(0)
VERTS = RNG.uniform([-3, 1, 5], [5, 3, 6], (200, 3))
FACES = np.arange(198).reshape(-1, 3)


def project(scene, points):
    """Image-plane coordinates in [-1, 1] (x right, y up) of points."""
    cam = scene.camera
    b = camera_buffer(cam, cam.width, cam.height)
    eye, fwd, right, up = b[:3], b[3:6], b[6:9], b[9:12]
    rel = points - eye
    depth = rel @ fwd
    assert np.all(depth > 0)
    return (rel @ right) / (right @ right) / depth, (rel @ up) / (up @ up) / depth


@pytest.mark.parametrize("up", UP_AXES)
@pytest.mark.parametrize("view", list(VIEWS))
@pytest.mark.parametrize("size", [(64, 48), (40, 90)])
def test_whole_mesh_in_frame_from_every_view(up, view, size):
    s = mesh_scene(VERTS, FACES, view=view, up=up, width=size[0], height=size[1])
    x, y = project(s, VERTS)
    assert np.abs(x).max() < 1 and np.abs(y).max() < 1
    # ... and it fills a fair part of the frame, not a speck in the middle.
    assert max(np.abs(x).max(), np.abs(y).max()) > 0.85
    cx, cy = project(s, ((VERTS.min(0) + VERTS.max(0)) / 2)[None])
    assert abs(cx[0]) < 1e-9 and abs(cy[0]) < 1e-9


@pytest.mark.parametrize("up", UP_AXES)
def test_ground_at_the_lowest_point_along_up(up):
    s = mesh_scene(VERTS, FACES, view="iso", up=up)
    planes = [o for o in s.objects if isinstance(o, Plane)]
    assert len(planes) == 1
    n = np.array(planes[0].normal)
    assert np.abs(n).sum() == 1 and n.sum() == (-1 if up.startswith("-") else 1)
    assert np.dot(planes[0].point, n) == pytest.approx((VERTS @ n).min())
    assert np.dot(s.lights[0].position, n) > (VERTS @ n).max()   # the light is above


def test_no_ground_when_looking_from_below():
    s = mesh_scene(VERTS, FACES, view="bottom")
    assert not [o for o in s.objects if isinstance(o, Plane)]


@pytest.mark.parametrize("up, view, expect", [
    ("y", "front", (0, 0, 1)), ("y", "right", (1, 0, 0)), ("y", "top", (0, 1, 0)),
    ("y", "back", (0, 0, -1)), ("y", "left", (-1, 0, 0)),
    ("z", "front", (0, -1, 0)), ("z", "right", (1, 0, 0)), ("z", "top", (0, 0, 1)),
])
def test_named_views_look_from_the_expected_side(up, view, expect):
    d, cam_up = view_direction(up, *VIEWS[view])
    assert np.allclose(d, expect, atol=1e-12)
    assert abs(np.dot(d, cam_up)) < 1e-12 and np.linalg.norm(cam_up) == pytest.approx(1)


def test_iso_is_the_diagonal():
    d, _ = view_direction("y", *VIEWS["iso"])
    assert np.allclose(d, np.ones(3) / np.sqrt(3))


def test_azimuth_elevation_override_the_view():
    a = mesh_scene(VERTS, FACES, view="front", azimuth=90.0, elevation=0.0)
    b = mesh_scene(VERTS, FACES, view="right")
    assert np.allclose(a.camera.eye, b.camera.eye)
