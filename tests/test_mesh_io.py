"""Mesh files: good ones load in every format, bad ones give one error
naming the file (the command line's side is in test_cli_files.py)."""
import numpy as np
import pytest

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import read_mesh

TRI_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
QUAD_OBJ = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"


def tetra():
    import trimesh
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return trimesh.Trimesh(v, f, process=False)


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_every_format_loads(tmp_path, ext):
    path = tmp_path / f"tetra.{ext}"
    tetra().export(path)
    v, f = read_mesh(path)
    assert f.shape == (4, 3) and f.dtype == np.int64 and v.dtype == np.float64
    assert np.allclose(v.min(axis=0), 0) and np.allclose(v.max(axis=0), 1)


def test_quads_are_split_into_triangles(tmp_path):
    (tmp_path / "quad.obj").write_text(QUAD_OBJ)
    v, f = read_mesh(tmp_path / "quad.obj")
    assert f.shape == (2, 3)


def test_shipped_house_is_closed_and_outward():
    from raytrace.scene.assets import assets_dir
    v, f = read_mesh(assets_dir() / "house.obj")
    assert f.shape == (14, 3)
    # Signed volume of a closed, outward-wound mesh: cube 1 + roof 1 * 0.6 / 3.
    vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
    assert vol == pytest.approx(1.2)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)   # every edge shared by exactly two triangles: watertight


def bad_mesh_files(tmp_path):
    """name -> (bytes, words the error must contain)."""
    good = tmp_path / "good.stl"
    tetra().export(good)
    stl = good.read_bytes()
    good_ply = tmp_path / "good.ply"
    tetra().export(good_ply)
    ply = good_ply.read_bytes()
    good_glb = tmp_path / "good.glb"
    tetra().export(good_glb)
    glb = good_glb.read_bytes()
    rng = np.random.default_rng(1)
    garbage = rng.integers(0, 256, 3000, dtype=np.uint8).tobytes()
    return {
        "empty.obj": (b"", "empty"),
        "empty.stl": (b"", "empty"),
        "comments.obj": (b"# nothing here\n", "no non-degenerate triangles"),
        "garbage.obj": (garbage, ""),
        "garbage.stl": (garbage, ""),
        "garbage.ply": (garbage, ""),
        "garbage.off": (garbage, ""),
        "garbage.glb": (garbage, ""),
        "truncated.stl": (stl[:len(stl) // 2], ""),
        "truncated.ply": (ply[:len(ply) - 10], ""),
        "truncated.glb": (glb[:len(glb) // 2], ""),
        "nan.obj": (b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "NaN"),
        "inf.off": (b"OFF\n3 1 0\n0 0 0\ninf 0 0\n0 1 0\n3 0 1 2\n", "NaN or infinite"),
        "range.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ""),
        "range.off": (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "range"),
        "point.obj": (b"v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n", None),
        "range.ply": (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "out of range"),
    }


@pytest.fixture
def bad_dir(tmp_path):
    d = tmp_path / "bad"
    d.mkdir()
    files = {}
    for name, (data, words) in bad_mesh_files(tmp_path).items():
        (d / name).write_bytes(data)
        files[name] = words
    return d, files


def test_bad_mesh_files_raise_naming_the_file(bad_dir):
    d, files = bad_dir
    for name, words in files.items():
        if words is None:      # reads, but cannot be shown (see test_cli_files)
            continue
        with pytest.raises(RaytraceError) as info:
            read_mesh(d / name)
        msg = str(info.value)
        assert msg.startswith(str(d / name) + ": "), msg
        assert words in msg, msg
        assert "\n" not in msg


def test_missing_and_directory(tmp_path):
    with pytest.raises(RaytraceError, match="no such file"):
        read_mesh(tmp_path / "nope.obj")
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(RaytraceError, match="is a directory"):
        read_mesh(tmp_path / "dir.obj")


def test_gltf_with_its_buffers_beside_it_reads_as_the_glb(tmp_path):
    """A JSON .gltf is a mesh file, not a scene name: it and its .bin
    buffers give the same triangles as the same scene as one .glb."""
    import trimesh

    import raytrace
    mesh = trimesh.creation.icosphere(1)
    for name, data in trimesh.exchange.gltf.export_gltf(trimesh.Scene(mesh)).items():
        (tmp_path / name).write_bytes(data)
    (tmp_path / "model.glb").write_bytes(trimesh.exchange.gltf.export_glb(trimesh.Scene(mesh)))
    a = raytrace.load_scene(str(tmp_path / "model.gltf")).objects[0]
    b = raytrace.load_scene(str(tmp_path / "model.glb")).objects[0]
    assert len(a.faces) == len(mesh.faces) == 80
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    (tmp_path / "gltf_buffer_0.bin").unlink()
    with pytest.raises(raytrace.RaytraceError, match="model.gltf"):
        raytrace.load_scene(str(tmp_path / "model.gltf"))
