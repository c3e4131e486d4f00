"""STL files: binary and ASCII ones read here (ASCII of several solids or
in capitals by trimesh), all welded; the triangles are trimesh's, bit for
bit."""
import numpy as np
import pytest
import trimesh

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import _read_with_trimesh, read_mesh_parts
from raytrace.scene.formats.stl import read_ascii_stl, read_binary_stl, weld

# Every test with the kernels compiled and as Python (conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_and_python")


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
    assert (read_ascii_stl(path) is None) == (kind == "binary")
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


def ascii_stl(corners, crlf=False, name="ball", normals="0 0 1"):
    """An ASCII STL of (m, 3, 3) corners, as exporters lay it out."""
    out = [f"solid {name}"]
    for tri in corners:
        out += [f"  facet normal {normals}", "    outer loop"]
        out += ["      vertex %r %r %r" % tuple(c) for c in tri.tolist()]
        out += ["    endloop", "  endfacet"]
    out.append(f"endsolid {name}")
    return (("\r\n" if crlf else "\n").join(out) + "\n").encode()


@pytest.mark.parametrize("crlf", [False, True])
def test_ascii_layouts_read_as_trimesh_reads_them(tmp_path, crlf):
    """Tabs, blank lines, CRLF ends, numbers of every form: our reading and
    trimesh's (then welded) give the same corners, bit for bit."""
    s = sphere()
    rng = np.random.default_rng(2)
    corners = s.vertices[s.faces] * rng.choice([1.0, 1e-7, 3e12], s.faces.shape)[..., None]
    text = ascii_stl(corners, crlf).replace(b"      vertex", b"\tvertex ").replace(b"endloop", b"\nendloop")
    path = tmp_path / "a.stl"
    path.write_bytes(text)
    fast = read_ascii_stl(path)
    (part,) = read_mesh_parts(path)
    (ref,) = _read_with_trimesh(path, ".stl", None, lambda m: None, None)
    assert np.array_equal(fast[0][fast[1]], np.asarray(ref.vertices)[ref.faces])
    assert np.array_equal(part.vertices, fast[0]) and np.array_equal(part.faces, fast[1])
    assert np.array_equal(fast[0][fast[1]], corners)
    assert len(np.unique(fast[1])) == len(fast[0]) < 3 * len(corners)     # welded


@pytest.mark.parametrize("chunk, halves", [(97, False), (1 << 12, False), (1 << 12, True),
                                          (1 << 16, True)])
def test_ascii_stl_welded_chunk_by_chunk_is_welded_as_a_whole(tmp_path, monkeypatch, chunk,
                                                              halves):
    """An ASCII STL is welded a chunk at a time into one table, which
    grows as it fills (from 16 slots here), each chunk read on one thread
    or in two halves at once: in small chunks (a line cut at every one,
    one line longer than a chunk) the vertices and faces are the whole
    file's welding's, and a number off the exact path (20 digits) lands
    in its own chunk's row."""
    from raytrace.scene import weld
    from raytrace.scene.formats import obj
    from raytrace.scene.normals import equal_rows
    s = trimesh.creation.icosphere(subdivisions=3, radius=1.3)
    corners = s.vertices[s.faces]
    long_digits = b"0.12345678901234567891"
    corners[7, 1, 0] = float(long_digits)
    text = ascii_stl(corners).replace(b"outer loop", b"outer loop" + b" " * 150, 1)
    assert repr(float(corners[7, 1, 0])).encode() in text
    path = tmp_path / "a.stl"
    path.write_bytes(text.replace(repr(float(corners[7, 1, 0])).encode(), long_digits, 1))
    monkeypatch.setattr(obj, "CHUNK", chunk)
    monkeypatch.setattr(weld, "FIRST_VALUES", 1)
    halves_read = []
    if halves:
        monkeypatch.setattr(obj, "SPLIT_MIN", 0)
        monkeypatch.setattr(obj, "_threads", lambda: 2)
        real = obj._halves
        monkeypatch.setattr(obj, "_halves", lambda *a: halves_read.append(1) or real(*a))
    vertices, faces = read_ascii_stl(path)
    assert bool(halves_read) == halves
    ids, values, count = equal_rows(corners.reshape(-1, 3))
    assert count == len(s.vertices) + 1
    assert np.array_equal(vertices, values) and np.array_equal(faces, ids.reshape(-1, 3))
    assert vertices[faces[7, 1], 0] == float(long_digits)


@pytest.mark.parametrize("chunk", [2, 5])
def test_an_error_in_the_welding_thread_is_the_readers(tmp_path, monkeypatch, chunk):
    """The corners are welded on a thread of their own (obj._Welding): a
    weld that fails (memory), at the first chunk or a later one, is raised
    by the reader, which leaves no thread behind."""
    import threading

    from raytrace.scene import weld
    from raytrace.scene.formats import obj
    s = trimesh.creation.icosphere(subdivisions=2)
    path = tmp_path / "a.stl"
    path.write_bytes(ascii_stl(s.vertices[s.faces]))
    monkeypatch.setattr(obj, "CHUNK", 4096)
    real, calls = weld.first_rows, []

    def failing(*args):
        calls.append(1)
        if len(calls) == chunk:
            raise MemoryError("no room")
        return real(*args)
    monkeypatch.setattr(weld, "first_rows", failing)
    before = threading.active_count()
    with pytest.raises(RaytraceError, match="out of memory"):
        read_mesh_parts(path)
    assert len(calls) >= chunk and threading.active_count() == before


def test_ascii_files_trimesh_reads_otherwise_are_left_to_it(tmp_path):
    """Several solids (trimesh makes each a mesh) and capitals: still read,
    by trimesh."""
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)
    two = tmp_path / "two.stl"
    two.write_bytes(ascii_stl(tri, name="a") + ascii_stl(tri + 2, name="b"))
    caps = tmp_path / "caps.stl"
    caps.write_bytes(ascii_stl(tri).upper())
    for path, parts in ((two, 2), (caps, 1)):
        assert read_ascii_stl(path) is None
        assert len(read_mesh_parts(path)) == parts


@pytest.mark.parametrize("text, words", [
    (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n"
     b"endsolid x\n", "not a readable STL mesh (2 vertices, not 3 a facet)"),
    (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 q\n",
     "not a readable STL mesh (line 6: 'q' is not a number)"),
    (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1\n",
     "not a readable STL mesh (line 6: a vertex of fewer than 3 coordinates"),
])
def test_damaged_ascii_stl_is_refused_in_one_line(tmp_path, text, words):
    path = tmp_path / "bad.stl"
    path.write_bytes(text)
    with pytest.raises(RaytraceError) as info:
        read_mesh_parts(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and words in msg and "\n" not in msg, msg


@pytest.mark.parametrize("where", [0.1, 0.2, 0.3, 0.95])
@pytest.mark.parametrize("bad", [b"1.0 2.0x 3.0", b"1.0 2.0"])
def test_a_damaged_ascii_stl_read_in_halves_names_the_line_one_thread_names(tmp_path, monkeypatch,
                                                                             where, bad):
    """A bad number (NumPy's parser finds it) or a short vertex (the
    kernel does) in either half of any chunk read on two threads is
    refused with one thread's message: the same line."""
    from raytrace.scene.formats import obj
    s = trimesh.creation.icosphere(subdivisions=2)
    lines = ascii_stl(s.vertices[s.faces]).split(b"\n")
    k = next(i for i in range(int(len(lines) * where), len(lines)) if b"vertex" in lines[i])
    lines[k] = b"      vertex " + bad
    path = tmp_path / "bad.stl"
    path.write_bytes(b"\n".join(lines))
    monkeypatch.setattr(obj, "CHUNK", 1 << 14)       # 5 chunks
    messages = []
    for split in (1 << 30, 0):
        monkeypatch.setattr(obj, "SPLIT_MIN", split)
        monkeypatch.setattr(obj, "_threads", lambda: 2)
        with pytest.raises(RaytraceError) as err:
            read_ascii_stl(path)
        messages.append(str(err.value))
    assert messages[0] == messages[1] and f"line {k + 1}:" in messages[0], messages


@pytest.mark.parametrize("kind", ["binary", "ascii"])
def test_an_stl_is_split_at_creases_as_any_mesh_without_hashing_its_welded_vertices(tmp_path,
                                                                                    kind):
    """An STL's vertices come welded (no two at one position), so the
    crease split does not hash them again: the same split as hashing."""
    from raytrace.scene.normals import shading_split
    c = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=24)
    path = tmp_path / "c.stl"
    path.write_bytes(trimesh.exchange.stl.export_stl(c) if kind == "binary"
                     else trimesh.exchange.stl.export_stl_ascii(c).encode())
    (part,) = read_mesh_parts(path)
    assert part.welded and len(np.unique(part.vertices, axis=0)) == len(part.vertices)
    fast = shading_split(part.vertices, part.faces, welded=True)
    slow = shading_split(part.vertices, part.faces)
    assert len(fast[0]) > len(part.vertices)          # split at the rims
    assert all(np.array_equal(a, b) for a, b in zip(fast, slow))
