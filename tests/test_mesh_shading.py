"""Mesh files' shading: their own normals if they have them, else smooth
ones split at creases, or flat; only the shading changes, never a hit."""
import re

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner

import raytrace
from raytrace.cli.main import main
from raytrace.errors import RaytraceError
from raytrace.scene.model import Mesh
from tests.test_materials import GLASS_WARNING, MTL, OBJ


def meshes(scene):
    return [o for o in scene.objects if isinstance(o, Mesh)]


def box_with_normals():
    """A box whose vertex normals are not any that trimesh would compute:
    each leans towards +y, and they are twice unit length."""
    box = trimesh.creation.box()
    given = np.array(box.vertices) + [0.0, 1.0, 0.0]
    return box, 2 * given / np.linalg.norm(given, axis=1, keepdims=True)


@pytest.mark.parametrize("ext", ["obj", "ply", "glb"])
def test_file_normals_are_used_as_given(tmp_path, ext):
    box, given = box_with_normals()
    box.vertex_normals = given
    path = tmp_path / f"box.{ext}"
    if ext == "obj":
        path.write_text(trimesh.exchange.obj.export_obj(box, include_normals=True))
    else:
        box.export(path, **({"vertex_normal": True} if ext == "ply" else {}))
    (mesh,) = meshes(raytrace.load_scene(path))
    assert len(mesh.vertices) == 8
    order = [int(np.flatnonzero((box.vertices == p).all(axis=1))[0]) for p in mesh.vertices]
    assert np.allclose(mesh.normals, given[order] / 2, atol=1e-6)   # PLY and glTF keep float32


@pytest.mark.parametrize("ext", ["obj", "ply", "glb", "stl", "off"])
def test_files_without_normals_get_creased_ones(tmp_path, ext):
    path = tmp_path / f"box.{ext}"
    box = trimesh.creation.box()
    if ext == "obj":
        path.write_text(trimesh.exchange.obj.export_obj(box, include_normals=False))
    else:
        box.export(path)
    (mesh,) = meshes(raytrace.load_scene(path))
    used = np.unique(mesh.faces)     # an STL file's box has 36 vertices, 3 per face
    assert len(used) == 24 and len(np.unique(mesh.normals[used], axis=0)) == 6
    assert meshes(raytrace.load_scene(path, flat=True))[0].normals is None


def test_smooth_and_flat_hit_the_same_geometry(tmp_path):
    path = tmp_path / "cyl.obj"
    cyl = trimesh.creation.cylinder(radius=0.5, height=1.5, sections=16)
    path.write_text(trimesh.exchange.obj.export_obj(cyl, include_normals=False))
    out = {}
    for shading in ({"flat": True}, {"crease": 35.0}):
        scene = raytrace.load_scene(path, width=32, height=24, **shading)
        out[len(shading) and next(iter(shading))] = raytrace.render(scene, aov=True).aovs
    flat, smooth = out["flat"], out["crease"]
    assert (flat["primid"] >= 0).sum() > 100
    for name in ("depth", "primid"):
        assert flat[name].tobytes() == smooth[name].tobytes(), name
    side = flat["primid"] >= 0
    assert not np.array_equal(flat["normal"][side], smooth["normal"][side])


def test_shading_options_are_checked():
    with pytest.raises(RaytraceError, match="crease applies to mesh files only"):
        raytrace.load_scene("teapot", crease=20)
    with pytest.raises(RaytraceError, match="crease angle must be between 0 and 180"):
        raytrace.load_scene("bunny.obj", crease=200)
    with pytest.raises(RaytraceError, match="contradict"):
        raytrace.load_scene("bunny.obj", crease=20, flat=True)
    with pytest.raises(RaytraceError, match="flat must be True or False"):
        raytrace.load_scene("bunny.obj", flat="yes")


def scene_file(tmp_path, extra=""):
    (tmp_path / "two.mtl").write_text(MTL)
    (tmp_path / "two.obj").write_text(OBJ)
    path = tmp_path / "s.toml"
    path.write_text('[camera]\nposition = [3, 2, 4]\nlook_at = [0.5, 0.5, 0.5]\nwidth = 32\n'
                    'height = 24\n[[lights]]\nposition = [2, 5, 3]\n'
                    '[[objects]]\ntype = "mesh"\nfile = "two.obj"\n'
                    f'[[objects]]\ntype = "mesh"\nfile = "two.obj"\ntranslate = [0, 0, -2]\n{extra}')
    return path


@pytest.mark.filterwarnings("ignore::raytrace.errors.RaytraceWarning")   # the glass: not tested here
def test_scene_file_smooth_and_crease(tmp_path):
    scene = raytrace.load_scene(scene_file(tmp_path, "smooth = false\n"))
    assert [o.normals is None for o in scene.objects] == [False, False, True, True]
    scene = raytrace.load_scene(scene_file(tmp_path, "crease = 180\n"))
    sizes = [len(o.vertices) for o in scene.objects]   # the first two split at creases
    assert sorted(sizes[:2]) == [6, 7] and sorted(sizes[2:]) == [4, 5]
    for extra, words in (("crease = 181\n", "objects[1].crease: "),
                         ("smooth = 1\n", "objects[1].smooth: expected true or false"),
                         ("smooth = false\ncrease = 20\n", "objects[1].crease: only smooth")):
        with pytest.raises(RaytraceError, match=re.escape(words)):
            raytrace.load_scene(scene_file(tmp_path, extra))


def test_cli_warns_once_per_problem(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(main, [str(scene_file(tmp_path)), "-q"])
    assert r.exit_code == 0, r.output
    assert r.stderr.splitlines() == [
        f"warning: {GLASS_WARNING}"]
    assert (tmp_path / "s.png").exists()


@pytest.mark.parametrize("args, words, code", [
    (["teapot", "--crease", "20"], "--crease applies to mesh files only", 2),
    (["teapot", "--flat"], "--flat applies to mesh files only", 2),
    (["two.obj", "--crease", "20", "--flat"], "--crease and --flat contradict", 2),
    (["two.obj", "--crease", "-1"], "--crease", 2)])
def test_cli_shading_usage_errors(tmp_path, monkeypatch, args, words, code):
    monkeypatch.chdir(tmp_path)
    scene_file(tmp_path)
    r = CliRunner().invoke(main, args)
    assert r.exit_code == code and words in r.output and "Traceback" not in r.output
