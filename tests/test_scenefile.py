"""TOML scene files: the shipped examples load as intended; every mistake
in a file is one error naming the file and the key."""
import numpy as np
import pytest

from raytrace.errors import RaytraceError
from raytrace.renderer.driver import RenderOptions, light_buffers, validate
from raytrace.scene.assets import assets_dir
from raytrace.scene.builtin import spheres, teapot
from raytrace.scene.examples import example_files
from raytrace.scene.flatten import flatten
from raytrace.scene.formats.scenefile import read_scene_file, teapot_details
from raytrace.scene.load import load_scene
from raytrace.scene.model import Mesh, Plane, Sphere
from raytrace.scene.transform import rotation, transform_mesh
from tests.conftest import scene_file_error


def same_scene(a, b):
    ga, ra, ia = flatten(a)
    gb, rb, ib = flatten(b)
    for name, x, y in zip(ga._fields, ga, gb):
        assert np.array_equal(x, y), name
    assert np.array_equal(ra, rb) and ia == ib
    assert a.camera == b.camera and a.lights == b.lights and a.background == b.background
    assert a.name == b.name


@pytest.mark.parametrize("name, factory", [("teapot", teapot), ("spheres", spheres)])
def test_builtin_scenes_as_files_are_the_same_scenes(name, factory):
    same_scene(read_scene_file(assets_dir() / f"{name}.toml"), factory())


def test_examples_are_listed_with_descriptions():
    files = {p.name: desc for p, desc in example_files()}
    assert {"teapot.toml", "spheres.toml", "village.toml"} <= set(files)
    assert all(files.values())


def test_village_places_the_house_mesh():
    s = read_scene_file(assets_dir() / "village.toml")
    meshes = [o for o in s.objects if isinstance(o, Mesh)]
    assert len(meshes) == 3 and isinstance(s.objects[3], Sphere) and isinstance(s.objects[4], Plane)
    house = meshes[0].vertices
    assert np.array_equal(house.min(axis=0), [-0.5, 0, -0.5]) and house[:, 1].max() == 1.6
    v, _ = transform_mesh(house, None, translate=(-2.2, 0, -1), rotate=(0, 30, 0), scale=(1.4,) * 3)
    assert np.allclose(meshes[1].vertices, v)
    assert meshes[2].vertices[:, 1].max() == pytest.approx(1.6 * 0.8)   # scale [1.6, 0.8, 1]
    assert s.objects[1].material is not s.objects[0].material
    assert s.objects[2].material is s.objects[0].material                # both "wall"
    # The rectangular light: 4 along z, 2 along x (it faces down).
    lights = light_buffers(s, "soft", 81)
    assert np.allclose(np.abs(lights.u[0]), [0, 0, 4]) and np.allclose(np.abs(lights.v[0]), [2, 0, 0])
    assert lights.samples.tolist() == [16, 1]


def test_rotation_is_about_fixed_axes_x_first():
    assert np.allclose(rotation((0, 90, 0)) @ [1, 0, 0], [0, 0, -1])
    assert np.allclose(rotation((90, 0, 0)) @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(rotation((90, 90, 0)) @ [0, 1, 0], [1, 0, 0])   # y -> z (x), z -> x (y)


def test_normals_stay_perpendicular_under_non_uniform_scale():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    n = np.array([[0, 0, 1.0]] * 3)
    v2, n2 = transform_mesh(v, n, rotate=(30, 40, 50), scale=(3, 0.5, 2))
    edge = v2[1] - v2[0], v2[2] - v2[0]
    assert abs(np.dot(edge[0], n2[0])) < 1e-12 and abs(np.dot(edge[1], n2[0])) < 1e-12


def test_mesh_paths_are_relative_to_the_file(tmp_path, monkeypatch):
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "s.toml").write_text(
        '[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n'
        '[[objects]]\ntype = "mesh"\nfile = "../models/tri.obj"\n')
    monkeypatch.chdir(tmp_path / "models")      # not where the scene file is
    s = load_scene(str(tmp_path / "scenes" / "s.toml"))
    assert s.objects[0].faces.tolist() == [[0, 1, 2]] and s.name == "s"


def test_per_light_samples_must_suit_the_pattern(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n'
                 '[[lights]]\ntype = "area"\nposition = [0, 5, 0]\nsize = 1\nsamples = 10\n')
    s = read_scene_file(f)
    validate(RenderOptions(shadows="soft", pattern="random"), s)
    with pytest.raises(RaytraceError, match=r"s.toml: lights\[0\].samples: the stratified "
                                            r"pattern needs a square number of light samples, got 10"):
        validate(RenderOptions(shadows="soft", pattern="stratified"), s)


CAMERA = '[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n'
SPHERE = '[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = 1\n'

# (file text, the whole expected message after "scene.toml: " or a part of it)
BAD = [
    ("[camera\nposition = [0, 0, 0]\n", "invalid TOML: "),
    (CAMERA + "x = = 1\n", "invalid TOML: "),
    ("camra = 1\n" + CAMERA, "camra: unknown key (expected one of: name, description, "),
    ("[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\npos = [1, 2, 3]\n", "camera.pos: unknown key"),
    (CAMERA + SPHERE + SPHERE + '[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = "big"\n',
     "objects[2].radius: expected a number, got 'big'"),
    (CAMERA + SPHERE.replace("radius = 1", "radius = 1\ncolour = [1, 0, 0]"),
     "objects[0].colour: unknown key (expected one of: type, center, radius, material)"),
    (CAMERA + '[[objects]]\ntype = "mesh"\nfile = "missing.obj"\n', "objects[0].file: "),
    (CAMERA + '[[objects]]\ntype = "mesh"\nfile = "broken.obj"\n', "broken.obj: no non-degenerate triangles"),
    (CAMERA + '[[objects]]\ntype = "mesh"\nfile = 3\n', "objects[0].file: expected a string, got 3"),
    (CAMERA + '[[objects]]\ntype = "mesh"\n', "objects[0]: missing key 'file'"),
    ('[[objects]]\ntype = "plane"\n', "missing table [camera]"),
    ("[camera]\nlook_at = [0, 0, 0]\n", "camera: missing key 'position'"),
    ("[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 0]\n", "camera.look_at: must differ"),
    (CAMERA.replace("[0, 1, 5]", "[0, 1]"), "camera.position: expected a list of 3 numbers, got [0, 1]"),
    (CAMERA + "fov = true\n", "camera.fov: expected a number, got True"),
    (CAMERA + "fov = 180\n", "camera.fov: must be between 0 and 180 degrees"),
    (CAMERA + "width = 640.5\n", "camera.width: expected an integer, got 640.5"),
    (CAMERA + "height = 0\n", "camera.height: must be between 1 and"),
    (CAMERA + '[[objects]]\ntype = "cube"\n',
     "objects[0].type: expected one of mesh, teapot, sphere, plane, quad, got 'cube'"),
    (CAMERA + '[[objects]]\nradius = 1\n', "objects[0]: missing key 'type'"),
    (CAMERA + SPHERE.replace("radius = 1", "radius = -1"), "objects[0].radius: must be positive, got -1"),
    (CAMERA + SPHERE.replace("[0, 0, 0]", "[0, nan, 0]"), "objects[0].center[1]: expected a finite number"),
    (CAMERA + SPHERE + 'material = "gold"\n',
     "objects[0].material: no material named 'gold' (defined: none)"),
    (CAMERA + '[materials.red]\ncolor = [1, 0]\n', "materials.red.color: expected a list of 3 numbers"),
    (CAMERA + '[materials.red]\ncolor = [1, -1, 0]\n', "materials.red.color[1]: must be at least 0"),
    (CAMERA + '[materials.red]\nshiny = 3\n', "materials.red.shiny: unknown key"),
    (CAMERA + '[materials]\nred = 3\n', "materials.red: expected a table, got 3"),
    ('materials = 3\n' + CAMERA, "materials: expected a table of named materials"),
    ('objects = 3\n' + CAMERA, "objects: expected an array of tables ([[objects]]), got 3"),
    (CAMERA + '[[lights]]\nposition = [0, 5, 0]\nsize = 2\n', "lights[0].size: only area lights"),
    (CAMERA + '[[lights]]\ntype = "area"\nposition = [0, 5, 0]\n', "lights[0]: missing key 'size'"),
    (CAMERA + '[[lights]]\ntype = "area"\nposition = [0, 5, 0]\nsize = [1, 0]\n',
     "lights[0].size[1]: must be positive"),
    (CAMERA + '[[lights]]\ntype = "area"\nposition = [0, 5, 0]\nsize = 1\nsamples = 0\n',
     "lights[0].samples: must be between 1 and 65536, got 0"),
    (CAMERA + '[[lights]]\ntype = "spot"\nposition = [0, 5, 0]\n',
     "lights[0].type: expected one of point, area, got 'spot'"),
    (CAMERA + '[[lights]]\ncolor = [1, 1, 1]\n', "lights[0]: missing key 'position'"),
    (CAMERA + '[[objects]]\ntype = "teapot"\ndetail = 0\n', "objects[0].detail: must be between 1 and 256"),
    (CAMERA + '[[objects]]\ntype = "teapot"\nscale = 0\n', "objects[0].scale: must be positive, got 0"),
    (CAMERA + '[[objects]]\ntype = "teapot"\nrotate = [0, "a", 0]\n',
     "objects[0].rotate[1]: expected a number, got 'a'"),
    (CAMERA + '[[objects]]\ntype = "plane"\nnormal = [0, 0, 0]\n',
     "objects[0].normal: must not be all zeros"),
    ('background = "blue"\n' + CAMERA, "background: expected a list of 3 numbers, got 'blue'"),
]


@pytest.fixture
def scene_dir(tmp_path):
    (tmp_path / "broken.obj").write_bytes(b"\x00\x01garbage\xff" * 50)
    return tmp_path


@pytest.mark.parametrize("text, message", BAD)
def test_bad_scene_files_name_the_file_and_key(scene_dir, text, message):
    path = scene_dir / "scene.toml"
    path.write_text(text)
    msg = scene_file_error(path)
    assert message in msg, msg


def test_unreadable_scene_files(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(CAMERA.encode() + b"name = '\xe9'\n")
    with pytest.raises(RaytraceError, match="latin1.toml: not UTF-8 text"):
        read_scene_file(bad)
    with pytest.raises(RaytraceError, match="nope.toml: no such file"):
        read_scene_file(tmp_path / "nope.toml")


def test_teapot_details_read_ahead_and_forgive_a_bad_file(tmp_path):
    """The details the command loads tessellation kernels for before the
    scene is read; a file it cannot read gives none (reading the scene
    then names the problem)."""
    good = tmp_path / "good.toml"
    good.write_text('[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n'
                    '[[objects]]\ntype = "teapot"\ndetail = 130\n'
                    '[[objects]]\ntype = "sphere"\nradius = 1\n'
                    '[[objects]]\ntype = "teapot"\n')
    assert teapot_details(good) == (130, 4)
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera\n")
    assert teapot_details(bad) == ()
    assert teapot_details(tmp_path / "missing.toml") == ()
    odd = tmp_path / "odd.toml"
    odd.write_text('objects = "teapot"\n')
    assert teapot_details(odd) == ()


def test_the_teapot_room_faces_inward_and_its_panel_lights_the_floor():
    """assets/teapot_room.toml: every quad's front (its corners' order)
    faces the room's inside, the emitting panel's down, so the path tracer
    sees the lit side of each."""
    s = read_scene_file(assets_dir() / "teapot_room.toml")
    quads = [o for o in s.objects if isinstance(o, Mesh) and len(o.faces) == 2]
    assert len(quads) == 6 and s.integrator == "path"
    centre = np.array([0.0, 4.5, 0.0])
    for q in quads:
        a, b, c = q.vertices[q.faces[0]]
        n = np.cross(b - a, c - a)
        assert np.dot(n, centre - a) > 0, q.name
    panel = [q for q in quads if any(q.material.emission)]
    assert len(panel) == 1
    a, b, c = panel[0].vertices[panel[0].faces[0]]
    assert np.cross(b - a, c - a)[1] < 0
