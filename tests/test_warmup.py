"""raytrace warmup: its tiny scenes give the render kernel the same types
as real scenes of each kind (so the kernels it compiles are the ones a real
render loads), and the command checks its arguments."""
import numba
import numpy as np
import pytest
from click.testing import CliRunner

import raytrace
from raytrace.cli.main import main
from raytrace.cli.warmup import plan
from raytrace.renderer.driver import RenderOptions, prepare
from raytrace.scene.kinds import tiny_scene as _scene


def _types(scene, **opts):
    setup = prepare(scene, RenderOptions(**opts))
    return [numba.typeof(x) for x in setup.payload()]


@pytest.mark.parametrize("name, textures, mirrors", [
    ("teapot", False, False), ("village", False, False), ("textured", True, False),
    ("whitted", False, True), ("glass_teapot", False, True)])
def test_warmup_scene_has_the_kernel_types_of_real_scenes(name, textures, mirrors):
    real = raytrace.load_scene(name, width=8, height=6)
    assert _types(real) == _types(_scene(textures, mirrors))
    soft = dict(shadows="soft", light_samples=4)
    assert _types(real, **soft) == _types(_scene(textures, mirrors), **soft)


def test_each_warmup_variant_is_a_kernel_of_its_own():
    """The control: textures and mirrors do change the types."""
    plain = _types(_scene(False, False))
    assert _types(_scene(True, False)) != plain and _types(_scene(False, True)) != plain


def test_plan_covers_each_combination_once():
    labels = [s.label for s in plan(["bvh", "grid"], ["none", "hard", "soft"], ["mirrors", "queries"])]
    renders = [x for x in labels if x.startswith("render")]
    assert len(renders) == 2 * 2 == len(set(renders))      # every shadow mode: one kernel
    assert "ray queries: bvh" in labels and "ray queries: grid" in labels
    assert [s.label for s in plan(["bvh"])] == ["render: bvh",
                                                "builders for big scenes"]


@pytest.mark.parametrize("args, message", [
    (["--accel", "octree"], "octree"), (["--shadows", "fuzzy"], "unknown mode 'fuzzy'"),
    (["--with", "sound"], "unknown feature 'sound'")])
def test_warmup_refuses_bad_arguments(args, message):
    r = CliRunner().invoke(main, ["warmup", *args])
    assert r.exit_code == 2 and message in r.output, r.output


def test_warmup_runs_and_reports_each_step():
    r = CliRunner().invoke(main, ["warmup", "--accel", "bvh"])
    assert r.exit_code == 0, r.output
    assert "[1/2] render: bvh ..." in r.output and "warm: 2 steps" in r.output


def test_query_warmup_casts_one_ray_and_packets(monkeypatch):
    """The queries step calls closest and any hit both below PACKET_MIN
    rays and at it: each side has kernels of its own (kernels/cast.py), and
    a warmup that cast one ray left the first call of 64 rays compiling."""
    from raytrace.cast.rayscene import RayScene
    from raytrace.cli.warmup import _queries
    from raytrace.kernels.cast import PACKET_MIN
    seen = {}
    for name in ("cast_rays", "occluded", "count_intersections", "list_intersections"):
        monkeypatch.setattr(RayScene, name, lambda self, o, d, name=name: seen.setdefault(
            name, []).append(len(o)) or type("Hits", (), {"normal": None})())
    for name in ("contains", "distance"):
        monkeypatch.setattr(RayScene, name, lambda self, p, name=name: seen.setdefault(
            name, []).append(len(p)))
    _queries("bvh")()
    for name in ("cast_rays", "occluded"):
        assert min(seen[name]) < PACKET_MIN <= max(seen[name]), (name, seen[name])


def _kernel_signatures(dispatchers):
    return {d.__name__: set(map(str, d.signatures)) for d in dispatchers}


def test_loading_warmup_compiles_what_mesh_files_use(tmp_path):
    """After the loading step, reading mesh files (an OBJ without normals,
    a binary PLY of a triangle and a quad) adds no specialisation to the
    kernels that loading runs: warmup compiled the types a file has.  The
    step once named meshes but compiled only the big teapot's kernels."""
    from raytrace.cli.warmup import _loading
    from raytrace.scene import creases, weld
    from raytrace.scene.formats import objtext, polygons
    kernels = [weld.number_rows, creases.corner_lists, creases.face_frames, creases.fan_groups,
               creases.fan_normals, polygons.polygon_lists, objtext.parse_lines]
    _loading()
    warmed = _kernel_signatures(kernels)
    assert all(warmed.values()), warmed
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n"
                                    "f 1 2 3\nf 1 3 4\nf 1 2 5\n")
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n"
            "property float y\nproperty float z\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]], "<f4").tobytes()
    faces = bytes([3]) + np.array([0, 1, 4], "<i4").tobytes() + bytes([4]) + np.array(
        [0, 1, 2, 3], "<i4").tobytes()
    (tmp_path / "m.ply").write_bytes(head + v + faces)
    for name in ("m.obj", "m.ply"):
        raytrace.load_scene(str(tmp_path / name))
    assert _kernel_signatures(kernels) == warmed


@pytest.mark.parametrize("name, textures", [("cornell", False), ("whitted", False),
                                            ("textured", True)])
def test_path_warmup_scene_has_the_path_kernel_types_of_real_scenes(name, textures):
    """--with path renders tiny_scene(textures, mirrors) path traced: mirrors
    change nothing there, textures give the stage a variant of its own."""
    real = raytrace.load_scene(name, width=8, height=6)
    assert _types(real, integrator="path") == _types(_scene(textures, True), integrator="path")
    assert _types(real, integrator="path") != _types(_scene(not textures, True), integrator="path")
    labels = [s.label for s in plan(["bvh", "bvh:lbvh", "grid"], ["hard"], ["path", "textures"])]
    assert [x for x in labels if x.startswith("path")] == [
        "path tracer: bvh", "path tracer: bvh, textures", "path tracer: grid",
        "path tracer: grid, textures"]
