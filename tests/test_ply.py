"""The binary PLY fast path (raytrace/scene/formats/ply.py) reads what trimesh reads,
and leaves every other PLY to trimesh."""
from pathlib import Path

import numpy as np
import pytest

from raytrace.scene.formats.mesh import _read_with_trimesh, read_mesh_parts
from raytrace.scene.formats.ply import read_simple_ply


def write_ply(path, vertices, faces, *, endian="<", coord="float", index="int", count="uchar",
              normals=None, counts=None, extra_vertex=(), tail=b""):
    """A binary PLY written field by field, so the tests name its layout."""
    kinds = {"float": "f4", "double": "f8", "int": "i4", "uint": "u4", "uchar": "u1",
             "ushort": "u2", "short": "i2"}
    names = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else []) + list(extra_vertex)
    vtype = np.dtype([(n, endian + kinds[coord]) for n in names])
    vdata = np.zeros(len(vertices), vtype)
    for k, n in enumerate("xyz"):
        vdata[n] = vertices[:, k]
    if normals is not None:
        for k, n in enumerate(("nx", "ny", "nz")):
            vdata[n] = normals[:, k]
    counts = np.full(len(faces), 3) if counts is None else counts
    body = b"".join(np.array(c, endian + kinds[count]).tobytes()
                    + np.asarray(row[:c], endian + kinds[index]).tobytes()
                    for c, row in zip(counts, faces))
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[endian]
    header = [f"ply\nformat {fmt} 1.0\ncomment written by test_ply\n",
              f"element vertex {len(vertices)}\n"]
    header += [f"property {coord} {n}\n" for n in names]
    header += [f"element face {len(faces)}\nproperty list {count} {index} vertex_indices\n"
               "end_header\n"]
    Path(path).write_bytes("".join(header).encode() + vdata.tobytes() + body + tail)
    return path


def mesh(seed=0, n_vertices=50, n_faces=80):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n_vertices, 3)) * 1e3
    f = rng.integers(0, n_vertices, size=(n_faces, 3))
    n = rng.normal(size=(n_vertices, 3))
    return v, f, n / np.linalg.norm(n, axis=1, keepdims=True)


LAYOUTS = [dict(), dict(endian=">"), dict(coord="double"), dict(index="uint", count="ushort"),
           dict(normals=True), dict(endian=">", coord="double", normals=True)]


@pytest.mark.parametrize("layout", LAYOUTS,
                         ids=lambda d: ",".join(f"{k}={v}" for k, v in d.items()) or "plain")
def test_simple_layouts_read_as_trimesh_reads_them(tmp_path, layout):
    v, f, n = mesh()
    opts = dict(layout)
    if opts.pop("normals", False):
        opts["normals"] = n
    path = write_ply(tmp_path / "m.ply", v, f, **opts)
    fast = read_simple_ply(path)
    assert fast is not None, "the simple layout must take the fast path"
    (ref,) = _read_with_trimesh(path, ".ply", None, lambda m: None, None)
    vertices, faces, normals = fast
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    assert np.array_equal(vertices, np.asarray(ref.vertices, np.float64))
    assert np.array_equal(faces, np.asarray(ref.faces, np.int64))
    if "normals" in opts:
        assert np.array_equal(normals, np.asarray(ref.normals, np.float64))
    else:
        assert normals is None and ref.normals is None


def test_other_layouts_go_to_trimesh(tmp_path):
    v, f, _ = mesh()
    quads = np.concatenate([f, f[:, :1]], axis=1)
    cases = {
        "quads": dict(faces=quads, counts=np.full(len(f), 4)),
        "colours": dict(extra_vertex=("red",)),
        "trailing": dict(tail=b"\0"),
    }
    for name, opts in cases.items():
        faces = opts.pop("faces", f)
        path = write_ply(tmp_path / f"{name}.ply", v, faces, **opts)
        assert read_simple_ply(path) is None, name
    ascii_ply = tmp_path / "ascii.ply"
    ascii_ply.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                          b"property float y\nproperty float z\nelement face 1\n"
                          b"property list uchar int vertex_indices\nend_header\n"
                          b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    assert read_simple_ply(ascii_ply) is None
    # ... and trimesh still reads them: a quad becomes two triangles.
    (part,) = read_mesh_parts(tmp_path / "quads.ply")
    assert len(part.faces) == 2 * len(f)


def test_fast_path_keeps_the_usual_errors(tmp_path):
    from raytrace.errors import RaytraceError
    v, f, _ = mesh()
    f[7, 1] = len(v)
    path = write_ply(tmp_path / "range.ply", v, f)
    assert read_simple_ply(path) is not None
    with pytest.raises(RaytraceError, match="face 7 indexes a vertex out of range"):
        read_mesh_parts(path)
    v[3, 2] = np.nan
    path = write_ply(tmp_path / "nan.ply", v, f)
    with pytest.raises(RaytraceError, match="vertex 3 has a NaN"):
        read_mesh_parts(path)
