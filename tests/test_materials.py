"""A mesh file's own materials: MTL parsing, the mapping to Blinn-Phong,
and one-line warnings for what cannot be shown (the command line's side is
in test_mesh_shading.py)."""
import warnings

import numpy as np
import pytest

import raytrace
from raytrace.errors import RaytraceWarning
from raytrace.scene.formats.materials import gltf_material, mtl_material
from raytrace.scene.formats.mtl import parse_mtl
from raytrace.scene.model import Material, Mesh

MTL = """# two materials
newmtl red
Kd 0.8 0.125 0.1
Ks 0.6 0.3 0.0
Ns 50
newmtl glass
Kd 0.2 0.3 0.9
d 0.3
"""
OBJ = """mtllib two.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
usemtl red
f 1 3 2
f 1 4 3
usemtl glass
f 1 2 5
f 2 3 5
usemtl red
f 3 4 5
"""


GLASS_WARNING = ("two.obj: material 'glass' is transparent (d=0.3); rendered as unbending glass "
                 "letting 0.7 through")


def collect():
    messages = []
    return messages, messages.append


def test_mtl_values_and_line_numbers():
    messages, warn = collect()
    lib = parse_mtl("Kd 1 1 1\nnewmtl a\nKd 1 x 0\nKs 0.5\nNs 1e999\nillum 2\n", "a.mtl", warn)
    assert lib["a"].values == {"ks": (0.5, 0.5, 0.5), "illum": (2.0,)}
    assert messages == ["a.mtl: line 1: Kd before any newmtl; ignored",
                        "a.mtl: line 3: Kd: expected 3 numbers (r g b), got '1 x 0'; ignored",
                        "a.mtl: line 5: Ns: expected a number, got '1e999'; ignored"]


def test_mtl_mapping():
    messages, warn = collect()
    lib = parse_mtl(MTL, "two.mtl", warn)
    red = mtl_material(lib["red"], Material(), "two.obj", warn)
    assert red.color == (0.8, 0.125, 0.1) and red.specular == pytest.approx(0.3)
    assert red.shininess == 50 and red.diffuse == Material().diffuse and not messages
    glass = mtl_material(lib["glass"], Material(), "two.obj", warn)
    assert glass.color == (0.2, 0.3, 0.9)
    # A dissolve without a glass mode: see-through, unbent, said once.
    assert (glass.transmit, glass.ior, glass.reflect) == (pytest.approx(0.7), 1.0, 0.0)
    assert messages == [GLASS_WARNING]
    messages.clear()
    more = parse_mtl("newmtl m\nKs 0.5 0.7 0.9\nillum 3\nnewmtl bottle\nd 0.4\nillum 4\n"
                     "Ni 1.52\nnewmtl lens\nillum 6\nNi 1.7\n", "more.mtl", warn)
    mirror, bottle, lens = (mtl_material(more[k], Material(), "more.obj", warn)
                            for k in ("m", "bottle", "lens"))
    assert mirror.reflect == pytest.approx(0.7) and mirror.transmit == 0.0
    assert (bottle.transmit, bottle.ior) == (pytest.approx(0.6), 1.52)
    assert (lens.transmit, lens.ior) == (0.9, 1.7)
    assert not messages                 # mirrors and glass are rendered as such


def test_gltf_mapping():
    from trimesh.visual.material import PBRMaterial
    messages, warn = collect()
    plastic = gltf_material(PBRMaterial(name="p", baseColorFactor=[1.0, 0.5, 0.0, 1.0],
                                        metallicFactor=0.0, roughnessFactor=0.5),
                            Material(), "m.glb", warn)
    # 8-bit colour as trimesh keeps it; exponent 2/0.5^4 - 2 = 30; F0 0.04 * 38/8.
    assert plastic.color == pytest.approx((1.0, 128 / 255, 0.0))
    assert plastic.shininess == pytest.approx(30.0) and plastic.specular == pytest.approx(0.19)
    assert plastic.diffuse == Material().diffuse and not messages
    gold = gltf_material(PBRMaterial(name="gold", baseColorFactor=[1.0, 0.8, 0.3, 0.5],
                                     metallicFactor=1.0, roughnessFactor=0.2, alphaMode="BLEND"),
                         Material(), "m.glb", warn)
    assert gold.specular == 1.0 and gold.shininess == 1000.0
    assert gold.diffuse == pytest.approx(Material().diffuse / 2)
    assert gold.transmit == pytest.approx(1 - 128 / 255) and gold.ior == 1.0
    # Metallic 1, roughness 0.2: a mirror of weight 0.6, within 1 - transmit.
    assert gold.reflect == pytest.approx(min(0.6, 128 / 255))
    assert [m.split(";")[0] for m in messages] == [
        "m.glb: material 'gold' is transparent (alpha=0.502)",
        "m.glb: material 'gold' is a polished metal (metallic=1, roughness=0.2)"]


@pytest.fixture
def two_obj(tmp_path):
    (tmp_path / "two.mtl").write_text(MTL)
    (tmp_path / "two.obj").write_text(OBJ)
    return tmp_path / "two.obj"


def test_obj_groups_become_meshes_with_their_materials(two_obj):
    with pytest.warns(RaytraceWarning) as caught:
        scene = raytrace.load_scene(two_obj)
    meshes = [o for o in scene.objects if isinstance(o, Mesh)]
    colors = sorted((m.material.color, len(m.faces)) for m in meshes)
    assert colors == [((0.2, 0.3, 0.9), 2), ((0.8, 0.125, 0.1), 3)]
    assert [str(w.message) for w in caught] == [GLASS_WARNING]


def test_missing_or_broken_mtl_warns_and_loads(two_obj):
    (two_obj.parent / "two.mtl").unlink()
    with pytest.warns(RaytraceWarning, match=r"^two.obj: material library .*two.mtl: no such file; "
                                             r"rendered with the default material$"):
        scene = raytrace.load_scene(two_obj)
    assert sum(len(o.faces) for o in scene.objects if isinstance(o, Mesh)) == 5
    (two_obj.parent / "two.mtl").write_bytes(b"\x00\x01binary")
    with pytest.warns(RaytraceWarning, match="two.mtl: not a text file"):
        raytrace.load_scene(two_obj)
    (two_obj.parent / "two.mtl").write_text("newmtl red\nKd 1 x 0\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raytrace.load_scene(two_obj)
    assert [str(w.message) for w in caught] == [
        "two.mtl: line 2: Kd: expected 3 numbers (r g b), got '1 x 0'; ignored",
        "two.obj: material 'glass' is not in two.mtl; rendered with the default material"]


def test_scene_file_material_replaces_the_files(two_obj):
    (two_obj.parent / "s.toml").write_text(
        '[camera]\nposition = [3, 3, 3]\nlook_at = [0, 0, 0]\n'
        '[materials.wall]\ncolor = [0.5, 0.5, 0.5]\n'
        '[[objects]]\ntype = "mesh"\nfile = "two.obj"\n'
        '[[objects]]\ntype = "mesh"\nfile = "two.obj"\nmaterial = "wall"\n')
    with pytest.warns(RaytraceWarning) as caught:
        scene = raytrace.load_scene(two_obj.parent / "s.toml")
    assert [o.material.color for o in scene.objects[2:]] == [(0.5, 0.5, 0.5)] * 2
    assert {o.material.color for o in scene.objects[:2]} == {(0.2, 0.3, 0.9), (0.8, 0.125, 0.1)}
    assert len(caught) == 1   # the first object's; the second's material is the scene's


def test_gltf_file_materials(tmp_path):
    import trimesh
    from trimesh.visual.material import PBRMaterial
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
        name="paint", baseColorFactor=[0.2, 0.4, 0.6, 1.0], metallicFactor=0.0, roughnessFactor=1.0))
    box.export(tmp_path / "box.glb")
    scene = raytrace.load_scene(tmp_path / "box.glb")
    assert np.allclose(scene.objects[0].material.color, np.round(np.array([0.2, 0.4, 0.6]) * 255) / 255)
    assert scene.objects[0].material.shininess == 1.0


def test_toys_example_keeps_its_mtl_colours():
    from raytrace.scene.assets import assets_dir
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # a shipped example warns of nothing
        scene = raytrace.load_scene(assets_dir() / "toys.toml")
    colors = {m.material.color for m in meshes_of(scene)}
    assert colors == {(0.7, 0.1, 0.08), (0.08, 0.22, 0.65), (0.85, 0.6, 0.08), (0.12, 0.5, 0.18)}


def meshes_of(scene):
    return [o for o in scene.objects if isinstance(o, Mesh)]


def test_mesh_files_set_the_path_tracers_glossy_lobe(tmp_path):
    """MTL Ks and Ns, glTF metallic and roughness reach the renderer's
    material table as the glossy lobe's weight and exponent (the mean of
    Ks, or F0; at most what the diffuse albedo leaves)."""
    import trimesh
    from trimesh.visual.material import PBRMaterial

    from raytrace.kernels.buffers import MAT_DIFFUSE, MAT_GLOSSY, MAT_SHININESS
    from raytrace.scene.flatten import flatten
    (tmp_path / "g.mtl").write_text(
        "newmtl varnish\nKd 0.5 0.25 0.25\nKs 0.3 0.2 0.1\nNs 5000\nillum 2\n"
        "newmtl bright\nKd 0.9 0.9 0.9\nKs 0.6 0.6 0.6\nNs 40\n"
        "newmtl mirror\nKd 0.5 0.5 0.5\nKs 0.9 0.9 0.9\nillum 3\n"
        "newmtl matte\nKd 0.4 0.4 0.4\nKs 0.9 0.9 0.9\nillum 1\n")
    (tmp_path / "g.obj").write_text(
        "mtllib g.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nusemtl varnish\nf 1 2 3\n"
        "usemtl bright\nf 2 4 3\nusemtl mirror\nf 1 2 5\nusemtl matte\nf 1 5 3\n")
    plastic = trimesh.creation.box()
    plastic.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
        name="plastic", baseColorFactor=[0.2, 0.4, 0.6, 1.0], metallicFactor=0.0, roughnessFactor=0.5))
    metal = trimesh.creation.box().apply_translation((2, 0, 0))
    metal.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
        name="metal", baseColorFactor=[0.9, 0.6, 0.3, 1.0], metallicFactor=1.0, roughnessFactor=0.5))
    trimesh.Scene([plastic, metal]).export(tmp_path / "g.glb")

    def lobes(path):
        scene = raytrace.load_scene(path)
        geo, _, _, (prim_object, _) = flatten(scene, with_sources=True)
        rows = {}
        for p, k in enumerate(prim_object[:len(geo.tri_mat)]):
            par = geo.mat_param[geo.tri_mat[p]]
            rows[scene.objects[k].material.color] = (par[MAT_GLOSSY], par[MAT_SHININESS],
                                                     par[MAT_DIFFUSE])
        return rows

    obj = lobes(tmp_path / "g.obj")
    kd = obj[(0.9, 0.9, 0.9)][2]
    assert obj[(0.5, 0.25, 0.25)][:2] == (pytest.approx(0.2), 1000.0)   # mean Ks; Ns within 1..1000
    assert obj[(0.9, 0.9, 0.9)][:2] == (pytest.approx(1.0 - 0.9 * kd), 40.0)  # room left by Kd
    # A mirror's Ks is its traced reflection, illum 1 has no highlight: no lobe.
    assert obj[(0.5, 0.5, 0.5)][0] == 0.0 and obj[(0.4, 0.4, 0.4)][0] == 0.0 and len(obj) == 4
    glb = lobes(tmp_path / "g.glb")
    blue, gold = (tuple(np.round(np.array(c) * 255) / 255) for c in ((0.2, 0.4, 0.6), (0.9, 0.6, 0.3)))
    # Roughness 0.5: exponent 2 / 0.5^4 - 2 = 30 (Walter et al. 2007); F0 0.04, or the metal's colour.
    assert glb[blue][:2] == (pytest.approx(0.04), pytest.approx(30.0))
    assert glb[gold][:2] == (pytest.approx(np.mean(gold)), pytest.approx(30.0))
    assert glb[gold][2] * max(gold) + np.mean(gold) <= 1.0     # room enough: not cut
