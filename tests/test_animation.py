"""Camera paths: a turntable orbits in the documented direction and starts
at the still's camera exactly; keyframes interpolate and hold; a scene
file's [animation] table is checked like every other table."""
import math

import numpy as np
import pytest

from raytrace.errors import RaytraceError
from raytrace.scene.animation import Animation, Key, camera_path, keyframe_path, turntable
from raytrace.scene.load import load_scene
from raytrace.scene.model import Camera, Scene
from tests.conftest import scene_file_error

CAMERA = '[camera]\nposition = [0, 2, 6]\nlook_at = [0, 1, 0]\nfov = 50\n'
KEYS = ('[animation]\nframes = 11\n'
        '[[animation.keys]]\nframe = 2\nposition = [0, 2, 6]\nlook_at = [0, 1, 0]\nfov = 30\n'
        '[[animation.keys]]\nframe = 6\nposition = [8, 2, 2]\nlook_at = [0, 1, 4]\n')


def test_turntable_frame_0_is_the_still_camera_exactly():
    cam = Camera(eye=(0.1, 0.7, 3.3), look_at=(0.2, 0.3, -0.1), up=(0.1, 1.0, 0.2), fov=35.5,
                 width=33, height=17)
    cams = turntable(cam, 7)
    assert len(cams) == 7
    assert cams[0] == cam and cams[0].eye == cam.eye and cams[0].look_at == cam.look_at
    assert all(c.look_at == cam.look_at and c.up == cam.up and (c.fov, c.width, c.height) == (35.5, 33, 17)
               for c in cams)
    assert len({c.eye for c in cams}) == 7


def test_turntable_turns_counter_clockwise_seen_from_above():
    cams = turntable(Camera(eye=(0.0, 0.0, 5.0), look_at=(0.0, 0.0, 0.0)), 8)
    # Seen from +y, x to the right and z towards the viewer's feet: +z then +x is counter-clockwise.
    assert cams[2].eye == pytest.approx((5.0, 0.0, 0.0), abs=1e-12)
    assert cams[4].eye == pytest.approx((0.0, 0.0, -5.0), abs=1e-12)
    assert cams[6].eye == pytest.approx((-5.0, 0.0, 0.0), abs=1e-12)
    assert cams[1].eye == pytest.approx((5 / math.sqrt(2), 0.0, 5 / math.sqrt(2)))


def test_turntable_keeps_distance_and_height_along_a_tilted_up():
    up = np.array([0.3, 2.0, -0.5])
    cam = Camera(eye=(1.0, 4.0, 6.0), look_at=(0.5, 1.0, -1.0), up=tuple(up))
    cams = turntable(cam, 13)
    rel = np.array([c.eye for c in cams]) - cam.look_at
    axis = up / np.linalg.norm(up)
    assert np.allclose(np.linalg.norm(rel, axis=1), np.linalg.norm(rel[0]), rtol=1e-13)
    assert np.allclose(rel @ axis, rel[0] @ axis, rtol=1e-13)
    # The angle between consecutive eyes about the axis is 360/13 degrees.
    flat = rel - np.outer(rel @ axis, axis)
    cos = (flat[0] @ flat[1]) / (flat[0] @ flat[0])
    assert math.degrees(math.acos(cos)) == pytest.approx(360 / 13)
    assert np.cross(flat[0], flat[1]) @ axis > 0        # counter-clockwise about up


@pytest.mark.parametrize("n", [0, -1, 2.0, True, "4", 100001])
def test_turntable_frame_count_is_checked(n):
    with pytest.raises(RaytraceError, match="turntable must be an integer number of frames from 1 to 100000"):
        turntable(Camera(eye=(0, 0, 5), look_at=(0, 0, 0)), n)


def test_turntable_of_one_frame_is_the_still():
    cam = Camera(eye=(0, 0, 5), look_at=(0, 0, 0))
    assert turntable(cam, 1) == [cam]


def test_keyframes_interpolate_between_keys_and_hold_outside():
    cam = Camera(eye=(9.0, 9.0, 9.0), look_at=(0.0, 0.0, 0.0), fov=50.0, width=40, height=30)
    anim = Animation(frames=11, keys=(Key(2, (0.0, 2.0, 6.0), (0.0, 1.0, 0.0), 30.0),
                                      Key(6, (8.0, 2.0, 2.0), (0.0, 1.0, 4.0))))
    cams = keyframe_path(cam, anim)
    assert len(cams) == 11
    assert all(c.up == cam.up and (c.width, c.height) == (40, 30) for c in cams)
    # Held before the first key and after the last, the keys' values exactly.
    for i in (0, 1, 2):
        assert (cams[i].eye, cams[i].look_at, cams[i].fov) == ((0.0, 2.0, 6.0), (0.0, 1.0, 0.0), 30.0)
    for i in (6, 7, 10):
        assert (cams[i].eye, cams[i].look_at, cams[i].fov) == ((8.0, 2.0, 2.0), (0.0, 1.0, 4.0), 50.0)
    # Halfway (frame 4) and a quarter of the way (frame 3); the second key's
    # fov is the camera's.
    assert cams[4].eye == pytest.approx((4.0, 2.0, 4.0)) and cams[4].look_at == pytest.approx((0, 1, 2))
    assert cams[4].fov == pytest.approx(40.0)
    assert cams[3].eye == pytest.approx((2.0, 2.0, 5.0)) and cams[3].fov == pytest.approx(35.0)


def test_keyframes_of_one_key_hold_it():
    cam = Camera(eye=(9.0, 9.0, 9.0), look_at=(0.0, 0.0, 0.0))
    cams = keyframe_path(cam, Animation(frames=3, keys=(Key(1, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0)),)))
    assert [c.eye for c in cams] == [(1.0, 2.0, 3.0)] * 3 and {c.fov for c in cams} == {cam.fov}


def test_camera_path_chooses_turntable_then_keys():
    cam = Camera(eye=(0.0, 0.0, 5.0), look_at=(0.0, 0.0, 0.0))
    scene = Scene(name="s", camera=cam)
    with pytest.raises(RaytraceError, match=r"^scene 's' has no \[animation\] table; give --turntable N$"):
        camera_path(scene)
    assert camera_path(scene, turntable=4)[1].eye == pytest.approx((5.0, 0.0, 0.0))
    scene.animation = Animation(frames=2, keys=(Key(0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)),))
    assert [c.eye for c in camera_path(scene)] == [(1.0, 0.0, 0.0)] * 2
    assert len(camera_path(scene, turntable=5)) == 5      # the turntable wins


def test_scene_file_animation_loads_and_follows_fov_override(tmp_path):
    path = tmp_path / "anim.toml"
    path.write_text(CAMERA + '[[objects]]\ntype = "sphere"\ncenter = [0, 1, 0]\nradius = 1\n' + KEYS)
    scene = load_scene(str(path))
    assert scene.animation == Animation(frames=11, keys=(
        Key(2, (0.0, 2.0, 6.0), (0.0, 1.0, 0.0), 30.0), Key(6, (8.0, 2.0, 2.0), (0.0, 1.0, 4.0), None)))
    cams = camera_path(scene)
    assert len(cams) == 11 and cams[10].fov == 50.0 and cams[4].eye == pytest.approx((4, 2, 4))
    # A key without its own fov takes the camera's, as overridden.
    assert camera_path(load_scene(str(path), fov=70))[10].fov == 70.0
    assert load_scene(str(path), fov=70).animation.keys[0].fov == 30.0
    # A scene file without the table has none.
    path.write_text(CAMERA)
    assert load_scene(str(path)).animation is None


BAD = [
    (KEYS.replace("frames = 11", "frames = 11\nloop = true"),
     "animation.loop: unknown key (expected one of: frames, keys)"),
    (KEYS.replace("frame = 6\n", "frame = 6\nroll = 3\n"),
     "animation.keys[1].roll: unknown key (expected one of: frame, position, look_at, fov)"),
    ("[animation]\nframes = 3\n", "animation: missing [[animation.keys]]"),
    (KEYS.replace("frames = 11\n", ""), "animation: missing key 'frames'"),
    (KEYS.replace("frames = 11", "frames = 0"), "animation.frames: must be between 1 and 100000, got 0"),
    (KEYS.replace("frames = 11", "frames = 2.5"), "animation.frames: expected an integer, got 2.5"),
    (KEYS.replace("frame = 6", "frame = 2"),
     "animation.keys[1].frame: keys must be in strictly increasing frame order, got 2 after 2"),
    (KEYS.replace("frame = 6", "frame = 1"),
     "animation.keys[1].frame: keys must be in strictly increasing frame order, got 1 after 2"),
    (KEYS.replace("frame = 6", "frame = 11"), "animation.keys[1].frame: must be between 0 and 10, got 11"),
    (KEYS.replace("frame = 2", "frame = -1"), "animation.keys[0].frame: must be between 0 and 10, got -1"),
    (KEYS.replace("position = [8, 2, 2]", "position = [0, 1, 4]"),
     "animation.keys[1].look_at: must differ from position"),
    (KEYS.replace("position = [8, 2, 2]", "position = [0, 5, 4]"),
     "animation.keys[1].look_at: view direction (position to look_at) parallel to [camera] up"),
    (KEYS.replace("frame = 6\n", ""), "animation.keys[1]: missing key 'frame'"),
    (KEYS.replace("look_at = [0, 1, 4]\n", ""), "animation.keys[1]: missing key 'look_at'"),
    (KEYS.replace("position = [8, 2, 2]", "position = [8, 2]"),
     "animation.keys[1].position: expected a list of 3 numbers, got [8, 2]"),
    (KEYS.replace("fov = 30", "fov = 180"), "animation.keys[0].fov: must be between 0 and 180 degrees"),
    # Both keys are fine, but the eye passes through look_at at frame 4.
    (KEYS.replace("position = [8, 2, 2]\nlook_at = [0, 1, 4]", "position = [0, 0, -6]\nlook_at = [0, 1, 0]"),
     "animation.keys: frame 4, between keys[0] and keys[1]: position meets look_at"),
    ("[animation]\nframes = 3\nkeys = 3\n", "animation.keys: expected an array of tables"),
    ("animation = 3\n", "animation: expected a table, got 3"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_animation_tables_name_the_file_and_key(tmp_path, text, message):
    path = tmp_path / "scene.toml"
    path.write_text(text + CAMERA)
    msg = scene_file_error(path)
    assert message in msg, msg
