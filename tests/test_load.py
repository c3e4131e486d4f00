"""load_scene: one entry point for names, mesh files and scene files."""
import pytest

import raytrace
from raytrace.errors import RaytraceError
from raytrace.scene.assets import assets_dir
from raytrace.scene.load import scene_kind
from raytrace.scene.model import Plane


@pytest.mark.parametrize("name, kind", [
    ("teapot", "builtin"), ("spheres", "builtin"), ("a/b.OBJ", "mesh"), ("x.glb", "mesh"),
    ("x.ply", "mesh"), ("x.stl", "mesh"), ("x.off", "mesh"), ("s.toml", "toml"), ("teapot2", None),
    ("x.fbx", None),
])
def test_scene_kind(name, kind):
    assert scene_kind(name) == kind


def test_example_scene_by_short_name():
    by_name = raytrace.load_scene("village", width=32, height=24)
    by_path = raytrace.load_scene(str(assets_dir() / "village.toml"), width=32, height=24)
    assert by_name.name == by_path.name == "village"
    assert repr(by_name) == repr(by_path) and by_name.camera == by_path.camera


def test_loads_each_kind():
    assert len(raytrace.load_scene("teapot", detail=2).objects[0].faces) == 32 * 2 * 2 * 2
    s = raytrace.load_scene(str(assets_dir() / "house.obj"), view="front", up="y", width=80, height=60)
    assert s.name == "house" and s.camera.width == 80 and isinstance(s.objects[1], Plane)
    s = raytrace.load_scene(str(assets_dir() / "spheres.toml"), width=32, height=24, fov=40.0)
    assert (s.camera.width, s.camera.height, s.camera.fov) == (32, 24, 40.0)


@pytest.mark.parametrize("name, opts, message", [
    ("cube", {}, "unknown scene 'cube' .*scenes: .*spheres, stadium, teapot"),
    ("spheres", dict(detail=3), "teapot scene only"),
    ("teapot", dict(detail=0), "detail must be an integer from 1 to 256"),
    ("teapot", dict(view="top"), "view applies to mesh files only"),
    ("teapot", dict(up="z"), "up applies to mesh files only"),
    ("HOUSE", dict(view="sideways"), "unknown view 'sideways'"),
    ("HOUSE", dict(up="w"), "unknown up axis 'w'"),
    ("HOUSE", dict(elevation=95.0), "elevation must be between -90 and 90"),
])
def test_bad_options(name, opts, message):
    name = str(assets_dir() / "house.obj") if name == "HOUSE" else name
    with pytest.raises(RaytraceError, match=message):
        raytrace.load_scene(name, **opts)
