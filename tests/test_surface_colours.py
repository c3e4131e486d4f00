"""A mesh's own colours (issue 12): per-vertex colours and base-colour image
textures through texture coordinates, nearest or bilinear; read from OBJ +
MTL, PLY and glTF files."""
import warnings

import numpy as np
import pytest

import raytrace
from raytrace.errors import RaytraceError, RaytraceWarning
from raytrace.kernels.jit import python_callable
from raytrace.kernels.ray import Hit
from raytrace.kernels.texture import mesh_color, texture_rgb
from raytrace.renderer.driver import render
from raytrace.scene.assets import assets_dir
from raytrace.scene.flatten import flatten
from raytrace.scene.formats.materials import srgb_to_linear
from raytrace.scene.model import Camera, Material, Mesh, Scene

# Per-ray kernel functions are compiled without Python wrappers (kernels/jit.py).
mesh_color, texture_rgb = python_callable(mesh_color), python_callable(texture_rgb)

QUAD_V = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
QUAD_F = np.array([[0, 1, 2], [0, 2, 3]])
QUAD_UV = (QUAD_V[:, :2] + 1) / 2          # (0, 0) at the lower left corner
# Shows the colour alone: ambient 1, no diffuse or highlight, no lights.
FLAT = dict(ambient=1.0, diffuse=0.0, specular=0.0)


def quad_scene(texture=None, colors=None, uv=QUAD_UV, size=33):
    """The quad facing a camera whose view it overfills; an odd image size
    puts the middle pixel's ray through the quad's centre."""
    mesh = Mesh(QUAD_V, QUAD_F, Material(color=(1.0, 1.0, 1.0), texture=texture, **FLAT),
                colors=colors, uv=uv, name="quad")
    return Scene("quad", Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), fov=40.0, width=size,
                                height=size), objects=[mesh], lights=[])


def reference_texture(img, s, t, bilinear):
    """NumPy's answer: img rows top first, (0, 0) lower left, repeating."""
    h, w = img.shape[:2]
    x, y = (s % 1.0) * w, (t % 1.0) * h
    if not bilinear:
        return img[h - 1 - int(y) % h, int(x) % w]
    x, y = x - 0.5, y - 0.5
    i, j = int(np.floor(x)), int(np.floor(y))
    fx, fy = x - i, y - j
    out = 0.0
    for di, dj, wgt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                        (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        out = out + wgt * img[h - 1 - (j + dj) % h, (i + di) % w].astype(np.float64)
    return out


def test_texture_lookup_against_numpy():
    rng = np.random.default_rng(5)
    img = rng.random((3, 5, 3)).astype(np.float32)
    geo, _, _ = flatten(quad_scene(img))
    assert geo.mat_tex.tolist() == [[0, 5, 3]] and geo.tex_rgb.shape == (15, 3)
    for s, t in [*rng.uniform(-3, 3, (200, 2)), (0.0, 0.0), (1.0, 1.0), (0.1, 0.999999),
                 (1e12 + 0.25, -1e12 - 0.75)]:
        for bilinear in (False, True):
            got = texture_rgb(geo, 0, s, t, bilinear)
            assert np.allclose(got, reference_texture(img, s, t, bilinear), rtol=0, atol=1e-6), \
                (s, t, bilinear)


def test_vertex_colours_interpolate_and_multiply_texture():
    colors = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.5, 0.5, 0.5]])
    img = np.full((1, 1, 3), 0.5, np.float32)
    geo, _, _ = flatten(quad_scene(img, colors=colors))
    assert geo.vtx_color.shape == (4, 3) and geo.vtx_uv.shape == (4, 2)
    assert geo.tri_vertex.tolist() == QUAD_F.tolist()
    # Triangle 0 is vertices 0, 1, 2; u, v weigh the second and third.
    r, g, b = mesh_color(geo, Hit(1.0, 0, 0.2, 0.3), 0, True)
    assert np.allclose((r, g, b), 0.5 * np.array([0.5, 0.2, 0.3]), rtol=0, atol=1e-12)
    # Triangle 1 is vertices 0 (red), 2 (blue), 3 (grey).
    r, g, b = mesh_color(geo, Hit(1.0, 1, 0.2, 0.3), 0, True)
    assert np.allclose((r, g, b), 0.5 * np.array([0.5 + 0.15, 0.15, 0.2 + 0.15]), rtol=0,
                       atol=1e-12)
    plain, _, _ = flatten(quad_scene())
    assert plain.vtx_color.shape == (0, 3) and plain.vtx_uv.shape == (0, 2)
    assert plain.tri_vertex.shape == (0, 3)
    assert mesh_color(plain, Hit(1.0, 1, 0.2, 0.3), 0, True) == (1.0, 1.0, 1.0)


def test_rendered_texture_is_upright_and_filtered():
    # A 2x2 texture: its top left texel must land at the quad's top left.
    img = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 0]]], np.float32)
    nearest = render(quad_scene(img), texture_filter="none").linear
    assert np.array_equal(nearest[2, 2], img[0, 0]) and np.array_equal(nearest[2, -3], img[0, 1])
    assert np.array_equal(nearest[-3, 2], img[1, 0]) and np.array_equal(nearest[-3, -3], img[1, 1])
    # Nearest: only texel colours; bilinear blends them, and the middle
    # pixel (u, v = 0.5) is the mean of all four.
    assert {tuple(p) for p in nearest.reshape(-1, 3)} <= {tuple(c) for c in img.reshape(-1, 3)}
    smooth = render(quad_scene(img)).linear
    assert np.allclose(smooth[16, 16], img.reshape(-1, 3).mean(axis=0), atol=1e-6)
    assert len({tuple(p) for p in smooth.reshape(-1, 3)}) > 100


def test_textured_example_renders_as_brute_force_does():
    """The BVH against brute force only: a lookup depends on the hit alone,
    which every structure finds alike (test_render.py), and each structure
    would compile a textured kernel of its own (~6 s; bench.sh's
    structures section compares them all on this scene)."""
    scene = raytrace.load_scene(assets_dir() / "textured.toml", width=64, height=48)
    images = {name: render(scene, accel=name).linear for name in ("none", "bvh")}
    first = images["none"]
    assert np.array_equal(images["bvh"], first)
    # The crate's wood and the ball's hues are there, not the default grey.
    hues = first.reshape(-1, 3)
    assert (hues[:, 0] > 2 * hues[:, 2] + 0.02).sum() > 50        # brown wood
    assert (hues[:, 2] > 2 * hues[:, 0] + 0.02).sum() > 20        # blue on the ball


def test_obj_mtl_png_example_loads_without_warnings():
    from PIL import Image
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = raytrace.load_scene(assets_dir() / "textured.toml")
    crate, ball = (o for o in scene.objects if isinstance(o, Mesh))
    png = np.asarray(Image.open(assets_dir() / "crate.png").convert("RGB")) / 255.0
    assert np.allclose(crate.material.texture, srgb_to_linear(png), atol=1e-6)
    assert crate.uv.shape == (len(crate.vertices), 2)
    assert crate.uv.min() == 0.0 and crate.uv.max() == 1.0
    assert ball.colors.shape == (len(ball.vertices), 3) and ball.material.texture is None
    assert ball.colors.min() >= 0 and ball.colors.max() <= 1 and ball.colors.std() > 0.1


def test_srgb_decoding():
    assert srgb_to_linear(np.array([0.0, 1.0])).tolist() == [0.0, 1.0]
    assert srgb_to_linear(np.array([0.5]))[0] == pytest.approx(0.21404, abs=1e-5)
    assert srgb_to_linear(np.array([0.04]))[0] == pytest.approx(0.04 / 12.92)


def test_ply_vertex_and_face_colours(tmp_path):
    import trimesh
    mesh = trimesh.Trimesh(QUAD_V, QUAD_F, process=False,
                           vertex_colors=[[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255],
                                          [188, 188, 188, 255]])
    mesh.export(tmp_path / "v.ply")
    (m,) = raytrace.load_scene(tmp_path / "v.ply").objects[:1]
    order = np.lexsort(m.vertices.T)       # framing moves the mesh: compare by position
    want = srgb_to_linear(np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [188 / 255] * 3]))
    assert np.allclose(m.colors[order], want[np.lexsort(QUAD_V.T)])
    faces = trimesh.Trimesh(QUAD_V, QUAD_F, process=False,
                            face_colors=[[255, 0, 0, 255], [0, 0, 255, 255]])
    faces.export(tmp_path / "f.ply")
    (m,) = raytrace.load_scene(tmp_path / "f.ply").objects[:1]
    # A colour per face: each face gets vertices of its own.
    assert len(m.vertices) == 6 and m.faces.tolist() == [[0, 1, 2], [3, 4, 5]]
    assert m.colors.tolist() == [[1.0, 0.0, 0.0]] * 3 + [[0.0, 0.0, 1.0]] * 3


def test_gltf_base_colour_texture(tmp_path):
    import trimesh
    from PIL import Image
    img = (np.random.default_rng(1).random((4, 6, 3)) * 255).astype(np.uint8)
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(img),
                                                   baseColorFactor=[255, 128, 255, 255])
    quad = trimesh.Trimesh(QUAD_V, QUAD_F, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=QUAD_UV, material=material))
    quad.export(tmp_path / "q.glb")
    (m,) = raytrace.load_scene(tmp_path / "q.glb").objects[:1]
    assert np.allclose(m.material.texture, srgb_to_linear(img / 255.0), atol=1e-6)
    assert m.material.color == pytest.approx((1.0, 128 / 255, 1.0))
    order = np.lexsort(m.vertices.T)
    assert np.allclose(m.uv[order], QUAD_UV[np.lexsort(QUAD_V.T)])


OBJ_UV = "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\n"
OBJ_NO_UV = "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n"


@pytest.mark.parametrize("obj, png, message", [
    (OBJ_UV, False, r"texture map_Kd gone\.png could not be read; rendered with its Kd colour"),
    (OBJ_NO_UV, True, r"has a texture \(map_Kd gone\.png\) but the mesh has no texture "
                      r"coordinates; rendered with its Kd colour"),
])
def test_unusable_texture_warns_and_renders_plain(tmp_path, obj, png, message):
    from PIL import Image
    (tmp_path / "q.mtl").write_text("newmtl m\nKd 0.5 0.25 1\nmap_Kd gone.png\n")
    (tmp_path / "q.obj").write_text(obj)
    if png:
        Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "gone.png")
    with pytest.warns(RaytraceWarning, match=message):
        scene = raytrace.load_scene(tmp_path / "q.obj")
    mesh = scene.objects[0]
    assert mesh.material.texture is None and mesh.material.color == (0.5, 0.25, 1.0)
    assert render(scene, width=16, height=12).image.any()


def test_bad_colour_arrays_are_errors():
    with pytest.raises(RaytraceError, match=r"quad: its material has a texture but the mesh has "
                                            r"no texture coordinates \(uv\)"):
        flatten(quad_scene(np.ones((1, 1, 3)), uv=None))
    with pytest.raises(RaytraceError, match=r"quad: colors must have shape \(4, 3\)"):
        flatten(quad_scene(colors=np.ones((3, 3))))
    with pytest.raises(RaytraceError, match=r"quad: uv contain NaN or inf"):
        flatten(quad_scene(np.ones((1, 1, 3)), uv=np.full((4, 2), np.nan)))
    with pytest.raises(RaytraceError, match=r"texture must be an \(h, w, 3\) image"):
        flatten(quad_scene(np.ones((4, 4))))


def test_gltf_colour_0_beside_a_material_is_linear(tmp_path):
    """glTF's COLOR_0 with a material (trimesh keeps it as a vertex
    attribute): linear, as the glTF specification says, not sRGB-decoded."""
    import trimesh
    material = trimesh.visual.material.PBRMaterial(baseColorFactor=[255, 255, 255, 255])
    visual = trimesh.visual.TextureVisuals(uv=QUAD_UV, material=material)
    rgba = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [128, 128, 128, 255]],
                    np.uint8)
    visual.vertex_attributes["color"] = rgba
    trimesh.Trimesh(QUAD_V, QUAD_F, visual=visual, process=False).export(tmp_path / "c.glb")
    (m,) = raytrace.load_scene(tmp_path / "c.glb").objects[:1]
    order = np.lexsort(m.vertices.T)
    assert np.allclose(m.colors[order], (rgba[:, :3] / 255.0)[np.lexsort(QUAD_V.T)])


def _corner_colours(geo):
    """Each triangle's three corners' colours, (n, 3, 3), as the kernel
    reads them."""
    return geo.vtx_color[geo.tri_vertex]


@pytest.mark.parametrize("normals", [False, True])
def test_corner_rows_follow_each_mesh_and_its_dropped_faces(normals):
    """Colours are read per vertex through tri_vertex, which is tri_normal
    itself where every mesh's normals are its vertices' (no second array)
    and offset mesh by mesh otherwise: each kept triangle's corners get
    their own vertices' colours, a mesh without colours white, past a
    degenerate face dropped from the first mesh."""
    rng = np.random.default_rng(3)
    v = QUAD_V.copy()
    faces = np.array([[0, 1, 1], [0, 1, 2], [0, 2, 3]])     # the first is degenerate
    red = rng.random((4, 3))
    last = np.vstack([red[::-1], [[0.1, 0.2, 0.3]]])

    def up(n):
        return np.tile([0.0, 0.0, 1.0], (n, 1)) if normals else None

    meshes = [Mesh(v, faces, colors=red, normals=up(4)),
              Mesh(v + [0, 0, -1], QUAD_F, normals=up(4)),
              Mesh(np.vstack([v, v[:1]]) + [0, 0, -2], QUAD_F[:, ::-1] + 1, colors=last,
                   normals=up(5))]
    scene = Scene("three", Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0)), objects=meshes, lights=[])
    geo, _, info = flatten(scene)
    assert info["degenerate_dropped"] == 1
    want = np.concatenate([red[faces[1:]], np.ones((2, 3, 3)), last[QUAD_F[:, ::-1] + 1]])
    assert np.array_equal(_corner_colours(geo), want)
    assert geo.tri_vertex.dtype == np.int32
    assert np.shares_memory(geo.tri_vertex, geo.tri_normal) == normals
