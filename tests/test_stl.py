"""STL files: binary ones read here, ASCII ones by trimesh, both welded;
the triangles are trimesh's, bit for bit."""
import numpy as np
import pytest
import trimesh

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import _read_with_trimesh, read_mesh_parts
from raytrace.scene.formats.stl import read_binary_stl, weld


def sphere():
    s = trimesh.creation.icosphere(subdivisions=2, radius=1.7)
    s.vertices += [0.1, -0.2, 0.3]
    return s


@pytest.mark.parametrize("kind", ["binary", "ascii"])
def test_stl_reads_as_trimesh_reads_it_and_is_welded(tmp_path, kind):
    s = sphere()
    path = tmp_path / "s.stl"
    path.write_bytes(trimesh.exchange.stl.export_stl(s) if kind == "binary"
                     else trimesh.exchange.stl.export_stl_ascii(s).encode())
    assert (read_binary_stl(path) is None) == (kind == "ascii")
    (part,) = read_mesh_parts(path)
    (ref,) = _read_with_trimesh(path, ".stl", None, lambda m: None, None)
    assert len(ref.vertices) == 3 * len(s.faces)          # trimesh's soup
    assert np.array_equal(part.vertices[part.faces], np.asarray(ref.vertices)[ref.faces])
    assert len(part.vertices) == len(s.vertices) and part.normals is None


def test_weld_keeps_first_vertices_in_order():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0], [0, 0, 1], [-0.0, 0, 0]],
                 float)
    f = np.array([[0, 1, 2], [3, 4, 5], [6, 1, 2]])
    wv, wf = weld(v, f)
    # -0.0 is not 0.0 bit for bit: it stays a vertex of its own.
    assert wv.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [-0.0, 0, 0]]
    assert wf.tolist() == [[0, 1, 2], [1, 0, 3], [4, 1, 2]]
    assert np.array_equal(wv[wf], v[f])


def test_truncated_binary_stl_is_an_error(tmp_path):
    path = tmp_path / "cut.stl"
    path.write_bytes(trimesh.exchange.stl.export_stl(sphere())[:-20])
    assert read_binary_stl(path) is None
    with pytest.raises(RaytraceError, match="cut.stl"):
        read_mesh_parts(path)
