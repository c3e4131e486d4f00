"""The OBJ reader (scene/formats/obj.py) against trimesh's reading of the
same small files, written here from arrays in every face form; its exact
number parsing against Python's; and damaged files refused in one line
naming the file, the line and the problem."""
import numpy as np
import pytest
from click.testing import CliRunner

from raytrace.errors import RaytraceError
from raytrace.scene.formats import obj as objmod
from raytrace.scene.formats.mesh import _read_with_trimesh, read_mesh_parts
from raytrace.scene.formats.obj import read_obj

# Every test with the kernels compiled and as Python (conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_and_python")


def mesh_arrays(seed=0):
    """A closed mesh (a subdivided icosahedron, jittered) with normals and
    texture coordinates, each list in its own order so that a corner's
    three indices differ."""
    import trimesh
    rng = np.random.default_rng(seed)
    m = trimesh.creation.icosphere(1)
    v = m.vertices + rng.normal(0, 0.01, m.vertices.shape)
    n = v / np.linalg.norm(v, axis=1, keepdims=True)
    f = np.asarray(m.faces)
    pn = rng.permutation(len(n))           # normals listed in another order
    uv = rng.random((len(v) + 5, 2))
    pt = rng.permutation(len(v))
    return v, f, n[pn], np.argsort(pn), uv, pt


def write_obj(path, form="a/b/c", polygons=False, negative=False, crlf=False, extras=False):
    """An OBJ of mesh_arrays() with corners written in ``form``; polygons
    joins pairs of triangles sharing an edge into quads and a fan of three
    into a pentagon; negative writes every index counted back."""
    v, f, n, n_of_v, uv, t_of_v = mesh_arrays()
    lines = ["# a test mesh", "o ball", ""]
    if extras:
        lines += ["g part", "s 1", "l 1 2", "vp 0.5"]
    lines += ["v %r %r %r" % tuple(r) + ("   " if extras else "") for r in v.tolist()]
    lines += ["vt %r %r" % tuple(r) for r in uv.tolist()]
    lines += ["vn %r %r %r" % tuple(r) for r in n.tolist()]
    faces = [list(r) for r in f]
    if polygons:      # 20 quads and a pentagon among the triangles
        faces = [[a, b, c, (a + 5) % len(v)] for a, b, c in faces[:20]] + faces[20:] + [[0, 1, 2, 3, 4]]
    nv, nn, nt = len(v), len(n), len(uv)
    for face in faces:
        corners = []
        for a in face:
            iv, it, i_n = a + 1, t_of_v[a] + 1, n_of_v[a] + 1
            if negative:
                iv, it, i_n = iv - nv - 1, it - nt - 1, i_n - nn - 1
            corners.append(form.replace("a", str(iv)).replace("b", str(it)).replace("c", str(i_n)))
        lines.append("f " + " ".join(corners) + ("\t" if extras else ""))
        if extras and len(lines) % 7 == 0:
            lines += ["", "# between faces", "usemap off"]
    text = ("\r\n" if crlf else "\n").join(lines) + "\n"
    path.write_bytes(text.encode())
    return path


def by_trimesh(path):
    (part,) = _read_with_trimesh(path, ".obj", None, None, None)
    return part


def assert_same(path):
    """Our reading and trimesh's give the same triangles, corner by corner:
    positions and, where the file has them, normals."""
    ours = read_obj(path)
    theirs = by_trimesh(path)
    assert ours is not None
    assert np.array_equal(ours["vertices"][ours["faces"]], theirs.vertices[theirs.faces])
    if theirs.normals is None:
        assert ours["normals"] is None
    else:
        assert np.array_equal(ours["normals"][ours["faces"]], theirs.normals[theirs.faces])
    # trimesh keeps only the vertices faces use; so do we.
    assert len(np.unique(ours["faces"])) == len(ours["vertices"])
    return ours


@pytest.mark.parametrize("form", ["a", "a/b", "a//c", "a/b/c"])
@pytest.mark.parametrize("negative", [False, True])
def test_every_face_form_reads_as_trimesh_reads_it(tmp_path, form, negative):
    ours = assert_same(write_obj(tmp_path / "m.obj", form, negative=negative))
    assert (ours["normals"] is not None) == form.endswith("c")


@pytest.mark.parametrize("form", ["a", "a/b/c"])
def test_polygons_fan_as_trimesh_fans_them(tmp_path, form):
    ours = assert_same(write_obj(tmp_path / "m.obj", form, polygons=True))
    assert len(ours["faces"]) == 2 * 20 + 60 + 3


def test_only_quads_are_split_in_trimesh_order(tmp_path):
    path = tmp_path / "q.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 2 5 6 3\n")
    ours = assert_same(path)
    assert ours["faces"].tolist() == [[0, 1, 2], [1, 4, 5], [2, 3, 0], [5, 2, 1]]


@pytest.mark.parametrize("crlf", [False, True])
def test_comments_blank_and_other_lines_crlf_trailing_blanks(tmp_path, crlf):
    assert_same(write_obj(tmp_path / "m.obj", "a/b/c", crlf=crlf, extras=True))


def test_tabs_leading_blanks_and_inline_comments(tmp_path):
    """What trimesh does not read (it looks for "\\nv "): checked against
    the arrays themselves."""
    path = tmp_path / "t.obj"
    path.write_bytes(b"\xef\xbb\xbfv\t0 0 0\n  v 1\t0 0 # a comment\nv 0 1 0 1.0\n\tvn 0 0 1\n"
                     b"f\t1//1   2//1\t3//1 # a comment\n")
    ours = read_obj(path)
    assert ours["vertices"].tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert ours["faces"].tolist() == [[0, 1, 2]] and ours["normals"].tolist() == [[0, 0, 1]] * 3


def test_negative_indices_count_back_from_the_line(tmp_path):
    """The format's rule: -1 is the last vertex read before the face's line
    (trimesh counts from the file's last vertex)."""
    path = tmp_path / "n.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n"
                    "f 1 2 -1\n")
    ours = read_obj(path)
    v, f = ours["vertices"], ours["faces"]
    assert v[f].tolist() == [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[5, 5, 5], [6, 5, 5], [5, 6, 5]],
                             [[0, 0, 0], [1, 0, 0], [5, 6, 5]]]


def test_unused_vertices_are_dropped_as_trimesh_drops_them(tmp_path):
    path = tmp_path / "u.obj"
    path.write_text("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 8 8 8\nf 2 3 4\n")
    ours = assert_same(path)
    assert ours["vertices"].tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]


def tokens(rng, k):
    """Number tokens in the forms files hold, exact-path and not."""
    out = []
    for x in (rng.normal(0, 1, k) * 10.0 ** rng.integers(-30, 30, k)).tolist():
        form = rng.integers(0, 8)
        out.append(("%.8g" % x if form == 0 else "%.17g" % x if form == 1 else "%.6f" % x if form == 2
                    else "%.3e" % x if form == 3 else repr(x) if form == 4
                    else "%d" % rng.integers(-10**6, 10**6) if form == 5
                    else "%.20f" % (x % 1.0) if form == 6 else "+%.10fE%+d" % (x % 7, rng.integers(-25, 25))))
    return out + ["0", "-0", "+0.0", ".5", "5.", "-.25e1", "1e22", "9007199254740993",
                  "123456789012345678", "0.000000000000000000000001", "1" + "0" * 30, "4.9e-324",
                  "1e-400", "2.2250738585072011e-308", "1e999999", "-1e-999999", "7e+22", "7e23"]


@pytest.mark.parametrize("chunk", [1 << 24, 97])
def test_numbers_are_correctly_rounded(tmp_path, monkeypatch, chunk):
    """Every coordinate is Python's float() of its text, bit for bit: the
    exact path and NumPy's parser for the rest, across chunk edges."""
    monkeypatch.setattr(objmod, "CHUNK", chunk)
    rng = np.random.default_rng(3)
    words = tokens(rng, 6000)
    words += ["0"] * (-len(words) % 3)
    rows = np.array(words).reshape(-1, 3)
    k = len(rows)
    text = "".join(f"v {a} {b} {c}\n" for a, b, c in rows)
    text += "".join(f"f {i + 1} {(i + 1) % k + 1} {(i + 2) % k + 1}\n" for i in range(k))
    path = tmp_path / "n.obj"
    path.write_text(text)
    got = read_obj(path)["vertices"]
    want = np.array([[float(w) for w in r] for r in rows])
    assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist()


def test_long_lines_and_small_chunks(tmp_path, monkeypatch):
    """A face line longer than the buffer, and lines cut at every place."""
    monkeypatch.setattr(objmod, "CHUNK", 16)
    path = tmp_path / "big.obj"
    k = 40
    angles = np.linspace(0, 2 * np.pi, k, endpoint=False)
    text = "".join(f"v {np.cos(a)} {np.sin(a)} 0\n" for a in angles.tolist())
    text += "f " + " ".join(str(i + 1) for i in range(k)) + "\n"
    path.write_text(text)
    ours = assert_same(path)
    assert len(ours["faces"]) == k - 2


@pytest.mark.parametrize("chunk", [None, 61])
def test_lines_of_every_length_end_where_their_newline_is(tmp_path, monkeypatch, chunk):
    """A line's end is found eight bytes at a time (objtext.py): lines of 0
    to 40 bytes, at every offset from a word's start, and the file's last
    line without a newline, each read to its end and no further."""
    if chunk:
        monkeypatch.setattr(objmod, "CHUNK", chunk)
    lines, want = [], []
    for k in range(41):
        x = k * 0.5
        lines += [f"v {x} {k} 1", "#" + "x" * k, "", " " * (k % 9) + f"v {k} {x} 2" + "\t" * (k % 3)]
        want += [[x, k, 1.0], [k, x, 2.0]]
    n = len(want)
    lines += [f"f {i + 1} {i + 2} {i + 3}" for i in range(0, n - 2)]
    path = tmp_path / "lines.obj"
    path.write_bytes("\n".join(lines).encode())      # no newline after the last face
    got = read_obj(path)
    assert np.array_equal(got["vertices"], np.array(want))
    assert len(got["faces"]) == n - 2 and got["faces"][-1].tolist() == [n - 3, n - 2, n - 1]


@pytest.mark.parametrize("text, words", [
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
     "line 4: face index 9 is out of bounds: the file has 3 vertices"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -5\n", "line 4: face index -5 is out of bounds"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 0 1 2\n", "line 5: face uses vertex index 0"),
    (b"v 0 0 0\nv 1 0 0\nvn 0 0 1\nv 0 1 0\nf 1//1 2//0 3//1\n", "line 5: face uses normal index 0"),
    (b"v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", "line 2: 'zero' is not a number"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n", "line 4: '3x' is not a face corner"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/2/3/4 2 3\n", "line 4: '1/2/3/4' is not a face corner"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n", "line 3: a vertex of fewer than 3 coordinates"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 1\nf 1 2 3\n", "line 4: a normal of other than 3"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: a face of fewer than 3 corners"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999\n", "line 4: '99999999999' is not a face corner"),
    (b"", "file is empty"),
    (b"# only a comment\n\n", "no non-degenerate triangles"),
])
def test_damaged_files_are_refused_in_one_line(tmp_path, text, words):
    path = tmp_path / "bad.obj"
    path.write_bytes(text)
    with pytest.raises(RaytraceError) as info:
        read_mesh_parts(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and words in msg and "\n" not in msg, msg
    from raytrace.cli.main import main
    r = CliRunner().invoke(main, [str(path), "--width", "8", "--height", "6", "-o",
                                  str(tmp_path / "out.png")])
    assert r.exit_code == 1 and r.output.strip() == f"Error: {msg}", r.output


def test_a_number_error_names_its_line_across_chunks(tmp_path, monkeypatch):
    monkeypatch.setattr(objmod, "CHUNK", 32)
    path = tmp_path / "late.obj"
    path.write_text("v 0 0 0\n" * 20 + "v 1 1.5.5 0\n" + "f 1 2 3\n")
    with pytest.raises(RaytraceError, match=r"line 21: '1\.5\.5' is not a number"):
        read_obj(path)


def test_an_out_of_bounds_normal_drops_the_normals_with_a_warning(tmp_path):
    path = tmp_path / "n.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//7\n")
    told = []
    ours = read_obj(path, told.append)
    assert ours["normals"] is None and len(told) == 1 and "normal index is out of bounds" in told[0]
    assert by_trimesh(path).normals is None      # trimesh drops them too


@pytest.mark.parametrize("text", [
    "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n 3\n",
])
def test_what_trimesh_reads_is_left_to_it(tmp_path, text):
    """Materials, vertex colours and continued lines: read_obj declines,
    and the file still reads (through trimesh)."""
    path = tmp_path / "m.obj"
    path.write_text(text)
    assert read_obj(path) is None
    (part,) = read_mesh_parts(path)
    assert part.vertices[part.faces].tolist() == [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]]


def test_shading_is_the_same_both_ways(tmp_path, monkeypatch):
    """Through load_scene: the corners' shading normals (the file's, or
    the crease smoothing's where it has none) match trimesh's path."""
    import raytrace
    for form in ("a/b/c", "a/b"):
        path = write_obj(tmp_path / f"s{len(form)}.obj", form)
        fast = raytrace.load_scene(str(path)).objects[0]
        with monkeypatch.context() as m:
            m.setattr(objmod, "read_obj", lambda path, warn=None: None)
            slow = raytrace.load_scene(str(path)).objects[0]
        assert np.array_equal(fast.vertices[fast.faces], slow.vertices[slow.faces])
        assert np.array_equal(fast.normals[fast.faces], slow.normals[slow.faces])
