"""The binary PLY fast path (raytrace/scene/formats/ply.py) reads what trimesh reads,
and leaves every other PLY to trimesh."""
from pathlib import Path

import numpy as np
import pytest

from raytrace.scene.formats.mesh import _read_with_trimesh, read_mesh_parts
from raytrace.scene.formats.ply import read_simple_ply

# Every test with the kernels compiled and as Python (conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_and_python")


def write_ply(path, vertices, faces, *, endian="<", coord="float", index="int", count="uchar",
              normals=None, counts=None, extra_vertex=(), extra_face=(), comment="", tail=b""):
    """A binary PLY written field by field, so the tests name its layout.
    extra_vertex: names, or (type, name) pairs, of more vertex properties,
    filled with a ramp; extra_face: (type, name) pairs after the index list."""
    kinds = {"float": "f4", "double": "f8", "int": "i4", "uint": "u4", "uchar": "u1",
             "ushort": "u2", "short": "i2"}
    extra = [e if isinstance(e, tuple) else ("uchar", e) for e in extra_vertex]
    names = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else [])
    types = [coord] * len(names) + [t for t, _ in extra]
    names += [n for _, n in extra]
    vtype = np.dtype([(n, endian + kinds[t]) for t, n in zip(types, names)])
    vdata = np.zeros(len(vertices), vtype)
    for k, (_, n) in enumerate(extra):
        vdata[n] = (np.arange(len(vertices)) * (7 + k)) % 251
    for k, n in enumerate("xyz"):
        vdata[n] = vertices[:, k]
    if normals is not None:
        for k, n in enumerate(("nx", "ny", "nz")):
            vdata[n] = normals[:, k]
    counts = np.full(len(faces), 3) if counts is None else counts
    body = b"".join(np.array(c, endian + kinds[count]).tobytes()
                    + np.asarray(row[:c], endian + kinds[index]).tobytes()
                    + b"".join(np.array(i % 100, endian + kinds[t]).tobytes() for t, _ in extra_face)
                    for i, (c, row) in enumerate(zip(counts, faces)))
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[endian]
    header = [f"ply\nformat {fmt} 1.0\ncomment written by test_ply\n",
              f"element vertex {len(vertices)}\n"]
    header += [comment]
    header += [f"property {t} {n}\n" for t, n in zip(types, names)]
    header += [f"element face {len(faces)}\nproperty list {count} {index} vertex_indices\n"]
    header += [f"property {t} {n}\n" for t, n in extra_face] + ["end_header\n"]
    Path(path).write_bytes("".join(header).encode() + vdata.tobytes() + body + tail)
    return path


def mesh(seed=0, n_vertices=50, n_faces=80):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n_vertices, 3)) * 1e3
    f = rng.integers(0, n_vertices, size=(n_faces, 3))
    n = rng.normal(size=(n_vertices, 3))
    return v, f, n / np.linalg.norm(n, axis=1, keepdims=True)


LAYOUTS = [dict(), dict(endian=">"), dict(coord="double"), dict(index="uint", count="ushort"),
           dict(normals=True), dict(endian=">", coord="double", normals=True),
           dict(count="int", index="uint"), dict(quads=True), dict(quads=True, endian=">"),
           dict(extra_vertex=("red", "green", "blue")),
           dict(extra_vertex=("red", "green", "blue", "alpha"), normals=True),
           dict(extra_vertex=(("float", "confidence"), ("float", "s"), ("float", "t"), "red")),
           dict(extra_face=(("uchar", "flags"),), coord="double")]


@pytest.mark.parametrize("layout", LAYOUTS,
                         ids=lambda d: ",".join(f"{k}={v}" for k, v in d.items()) or "plain")
def test_simple_layouts_read_as_trimesh_reads_them(tmp_path, layout):
    v, f, n = mesh()
    opts = dict(layout)
    if opts.pop("normals", False):
        opts["normals"] = n
    if opts.pop("quads", False):
        f = np.concatenate([f, (f[:, :1] + 1) % len(v)], axis=1)
        opts["counts"] = np.full(len(f), 4)
    path = write_ply(tmp_path / "m.ply", v, f, **opts)
    fast = read_simple_ply(path)
    assert fast is not None, "this layout must take the fast path"
    (ref,) = _read_with_trimesh(path, ".ply", None, lambda m: None, None)
    assert fast["vertices"].dtype == np.float64 and fast["faces"].dtype == np.int64
    assert np.array_equal(fast["vertices"], np.asarray(ref.vertices, np.float64))
    assert np.array_equal(fast["faces"], np.asarray(ref.faces, np.int64))
    for attr in ("normals", "colors"):
        if getattr(ref, attr) is None:
            assert fast[attr] is None, attr
        else:
            assert np.array_equal(fast[attr], np.asarray(getattr(ref, attr), np.float64)), attr
    if "normals" in opts:
        assert fast["normals"] is not None
    if "green" in str(opts.get("extra_vertex")):
        assert fast["colors"] is not None


def test_other_layouts_go_to_trimesh(tmp_path):
    v, f, _ = mesh()
    cases = {
        "face colours": dict(extra_face=(("uchar", "red"), ("uchar", "green"), ("uchar", "blue"))),
        "float colours": dict(extra_vertex=(("float", "red"), ("float", "green"), ("float", "blue"))),
        "texture": dict(comment="comment TextureFile t.png\n",
                        extra_vertex=(("float", "s"), ("float", "t"))),
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
    # ... and trimesh still reads them.
    (part,) = read_mesh_parts(tmp_path / "face colours.ply")
    assert len(part.faces) == len(f) and part.face_colors is not None


def ascii_ply(path, vertices, polygons):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}", "property double x",
             "property double y", "property double z", f"element face {len(polygons)}",
             "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(repr(float(c)) for c in p) for p in vertices]
    lines += [" ".join(map(str, [len(p), *p])) for p in polygons]
    Path(path).write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("sizes", [(3, 4), (4, 3, 5, 4, 6), (5,), (3, 3, 3, 7)])
@pytest.mark.parametrize("endian", ["<", ">"])
def test_mixed_polygons_are_triangulated_as_trimesh_does(tmp_path, sizes, endian):
    """trimesh reads mixed polygons from ASCII PLY only; the binary file
    here must give the triangles it gives from the same polygons."""
    v, _, _ = mesh()
    rng = np.random.default_rng(5)
    counts = np.resize(sizes, 40)
    polygons = [rng.choice(len(v), size=k, replace=False) for k in counts]
    rows = np.zeros((len(counts), counts.max()), int)
    for r, p in zip(rows, polygons):
        r[:len(p)] = p
    path = write_ply(tmp_path / "m.ply", v, rows, coord="double", count="uchar", index="int",
                     counts=counts, endian=endian)
    fast = read_simple_ply(path)
    assert fast is not None
    (ref,) = _read_with_trimesh(ascii_ply(tmp_path / "a.ply", v, polygons), ".ply", None,
                                lambda m: None, None)
    assert np.array_equal(fast["vertices"], ref.vertices)
    assert np.array_equal(fast["faces"], ref.faces)
    assert len(fast["faces"]) == (counts - 2).sum()


def test_damaged_polygon_records_are_refused(tmp_path):
    from raytrace.errors import RaytraceError
    v, f, _ = mesh()
    counts = np.resize([3, 4], len(f))
    rows = np.concatenate([f, f[:, :1]], axis=1)
    cut = write_ply(tmp_path / "cut.ply", v, rows, counts=counts, tail=b"\0\0")
    assert read_simple_ply(cut) is None
    with pytest.raises(RaytraceError, match="cut.ply"):
        read_mesh_parts(cut)
    counts[5] = 2
    two = write_ply(tmp_path / "two.ply", v, rows, counts=counts)
    assert read_simple_ply(two) is None


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
