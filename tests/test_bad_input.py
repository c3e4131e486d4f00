"""Bad input through the command line and the Python API: one line naming
the file (or the argument) and the problem, a non-zero exit, no traceback,
no output file, and an existing output file left as it was.

test_mesh_io.py and test_cli_files.py already run every damaged mesh file
of bad_mesh_files() through the reader and the command line; this file
adds the public API (load_scene, render with a path), the files those
miss (vertex index 0 in an OBJ, coordinates too large to multiply, a
binary STL holding a NaN, a line cut short), existing outputs, image sizes
and unknown options.
"""
import struct

import numpy as np
import pytest
from click.testing import CliRunner

import raytrace
from raytrace import RaytraceError
from raytrace.cli.main import main
from tests.test_mesh_io import bad_mesh_files, tetra

SMALL = ["--width", "48", "--height", "36"]
OLD = b"an earlier render, to be left alone"


def more_bad_mesh_files(tmp_path):
    """name -> (bytes, words the error must contain)."""
    good = tmp_path / "good.stl"
    tetra().export(good)
    stl = bytearray(good.read_bytes())
    struct.pack_into("<f", stl, 84 + 12 + 4, float("nan"))   # triangle 0, vertex 0, y
    return {
        "zero_index.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 0 1 2\n",
                           "line 6: face uses vertex index 0, out of range (OBJ indices start at 1)"),
        "huge.obj": (b"v 0 0 0\nv 1e300 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1 has a coordinate of 1e+300"),
        "nan.stl": (bytes(stl), "vertex 0 has a NaN or infinite coordinate"),
        "cut.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1", "not a readable OBJ mesh"),
        "words.obj": (b"v a b c\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "not a readable OBJ mesh"),
        "negative.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -5\n", "out of bounds"),
    }


def all_bad(tmp_path):
    files = {**bad_mesh_files(tmp_path), **more_bad_mesh_files(tmp_path)}
    files["point.obj"] = (files["point.obj"][0], "no non-degenerate triangles")
    return files


@pytest.fixture
def bad_files(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    out = {}
    for name, (data, words) in all_bad(tmp_path).items():
        (d / name).write_bytes(data)
        out[d / name] = words
    return out


def test_api_names_the_file_and_the_problem(bad_files):
    for path, words in bad_files.items():
        for call in (lambda path=path: raytrace.load_scene(str(path)),
                     lambda path=path: raytrace.render(str(path), width=8, height=6)):
            with pytest.raises(RaytraceError) as info:
                call()
            msg = str(info.value)
            assert msg.startswith(f"{path}: ") and words in msg and "\n" not in msg, msg


def test_cli_bad_mesh_files_leave_an_existing_output_alone(bad_files, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "keep.png"
    out.write_bytes(OLD)
    for path, words in bad_files.items():
        r = CliRunner().invoke(main, [str(path), *SMALL, "-o", str(out)])
        assert r.exit_code == 1, r.output
        lines = r.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"Error: {path}: ") and words in lines[0], r.output
        assert "Traceback" not in r.output
    assert out.read_bytes() == OLD
    written = [p.name for p in tmp_path.iterdir() if p.suffix in (".png", ".npz", ".tmp")]
    assert written == ["keep.png"]


@pytest.mark.parametrize("args, code, words", [
    (["--width", "0"], 2, "Invalid value for '--width': 0 is not in the range 1<=x<=1048576"),
    (["--height", "-3"], 2, "Invalid value for '--height': -3 is not in the range 1<=x<=1048576"),
    # A bad argument exits 2 wherever it is found (the range comes from options.py).
    (["--width", "2000000"], 2, "Invalid value for '--width': 2000000 is not in the range"),
    (["--threads", "999"], 2, "threads must be between 1 and"),
    (["--leaf-size", "0"], 2, "Invalid value for '--leaf-size'"),
    (["--bvh-build", "sweep"], 2, "Invalid value for '--bvh-build'"),
    (["--grid-density", "0"], 2, "Invalid value for '--grid-density'"),
    (["--width", "1048576", "--height", "1048576"], 1, "a 1048576x1048576 image needs 1536"),
    (["--frobnicate"], 2, "--frobnicate"),
    (["--accel", "octree"], 2, "Invalid value for '--accel'"),
    (["--spp", "0"], 2, "Invalid value for '--spp'"),
])
def test_cli_bad_options_leave_an_existing_output_alone(tmp_path, monkeypatch, args, code, words):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "keep.png"
    out.write_bytes(OLD)
    r = CliRunner().invoke(main, ["spheres", *args, "-o", str(out)])
    assert r.exit_code == code, r.output
    errors = [ln for ln in r.output.splitlines() if ln.startswith("Error: ")]
    assert len(errors) == 1 and words in errors[0], r.output
    assert "Traceback" not in r.output
    assert out.read_bytes() == OLD and [p.name for p in tmp_path.iterdir()] == ["keep.png"]


def test_memory_refusal_counts_every_buffer(monkeypatch):
    """An image is refused, naming the memory it needs, when that is more
    than is available: the per-pixel buffers and the per-row counter rows,
    so a 1-pixel-wide, million-row image (95 MB) is not waved through."""
    from raytrace.renderer import driver
    scene = raytrace.load_scene("spheres")
    monkeypatch.setattr(driver, "available_memory", lambda: 64 << 20)
    with pytest.raises(RaytraceError, match=r"a 1x1048576 image needs 0\.\d GiB of memory, more than "
                                            r"the 0\.1 GiB available"):
        raytrace.render(scene, width=1, height=1 << 20)
    with pytest.raises(RaytraceError, match=r"a 4000x4000 image needs 0\.\d GiB"):
        raytrace.render(scene, width=4000, height=4000)


@pytest.mark.parametrize("call, words", [
    (lambda s: raytrace.render(s, frobnicate=1), "unknown option 'frobnicate'"),
    (lambda s: raytrace.render(s, width=0), "width must be between 1 and"),
    (lambda s: raytrace.render(s, height=-2), "height must be between 1 and"),
    (lambda s: raytrace.render(s, width=2.5), "width must be an integer, got 2.5"),
])
def test_api_bad_render_options(call, words):
    scene = raytrace.load_scene("spheres")
    with pytest.raises((RaytraceError, TypeError), match=words):
        call(scene)


def test_api_unknown_load_option():
    with pytest.raises(TypeError, match="frobnicate"):
        raytrace.load_scene("spheres", frobnicate=1)


@pytest.mark.parametrize("o, d, words", [
    ([[0, 0, 1e300]], [[0, 0, -1.0]], r"origins\[0\]: a value beyond 1e\+100"),
    ([[0, 0, 1.0]], [[0, 0, -1e200]], r"directions\[0\]: a value beyond 1e\+100"),
])
def test_api_rays_too_large_to_multiply(o, d, words):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    with pytest.raises(RaytraceError, match=words):
        raytrace.cast_rays((v, [[0, 1, 2]]), o, d, accel="none")
    with pytest.raises(RaytraceError, match="vertex 1 has a coordinate of 1e\\+200"):
        raytrace.cast_rays((v * [[1], [1e200], [1]], [[0, 1, 2]]), [[0, 0, 1.0]], [[0, 0, -1.0]],
                           accel="none")
