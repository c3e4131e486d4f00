"""Issue 45's last root causes (items 6, 7, 13, 14), one table each, in
test_hardening3.py's style: CLI cases run the real command in a new process
and assert its exit code and the one line it prints."""
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def lines(err):
    out = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert "Traceback" not in err, err
    return out


# --- 13: Ctrl-C in the console script's first milliseconds -----------------

def _pyproject():
    import tomllib
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _console_entry():
    """The module and function [project.scripts] names for `raytrace`."""
    module, _, function = _pyproject()["project"]["scripts"]["raytrace"].partition(":")
    return module, function


def test_13_console_entry_is_outside_the_package_and_shipped():
    """Importing anything in raytrace runs raytrace/__init__ first, before
    the entry's code could catch a Ctrl-C."""
    module, _ = _console_entry()
    assert "." not in module and (ROOT / f"{module}.py").is_file()
    assert module in _pyproject()["tool"]["setuptools"]["py-modules"]


@pytest.mark.parametrize("delay_ms", [0, 1, 2, 3, 5, 7, 10, 14, 20, 30])
def test_13_ctrl_c_while_the_console_script_imports(tmp_path, delay_ms):
    """The console script pip writes, run with -X importtime so the signal
    can be sent a given time after the first of our modules has loaded:
    before that, Python's own start-up and import machinery run, not our
    code."""
    module, function = _console_entry()
    script = f"import sys\nfrom {module} import {function}\nsys.exit({function}())\n"
    p = subprocess.Popen([sys.executable, "-X", "importtime", "-c", script, "spheres",
                          "--width", "16", "--height", "12", "-o", "x.png"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    for line in p.stderr:
        if line.rstrip().endswith("| site"):
            break
    first = next(ln for ln in p.stderr if ln.split("|")[-1].strip().startswith("raytrace"))
    time.sleep(delay_ms / 1000)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    err = "".join(ln for ln in err.splitlines(keepends=True) if not ln.startswith("import time:"))
    assert first.rstrip().endswith(f"| {module}")
    assert (p.returncode, lines(err)) == (130, ["interrupted: no image written"])
    assert list(tmp_path.iterdir()) == []


# --- 14: a PLY declaring more elements than it holds ------------------------

def _cube():
    import trimesh
    box = trimesh.creation.box()
    return box.vertices, box.faces


def _binary(endian, old, new, **opts):
    """A binary cube (8 vertices, 12 triangles) whose header says ``new``
    where it said ``old``."""
    def write(tmp):
        from tests.test_ply import write_ply
        v, f = _cube()
        if "counts" in opts:
            f = [[*row, row[0]] for row in f]     # room for a fourth index
        path = write_ply(tmp / "m.ply", v, f, endian=endian, **opts)
        path.write_bytes(path.read_bytes().replace(old, new, 1))
        return path
    return write


def _ascii(old, new):
    def write(tmp):
        import trimesh
        path = tmp / "m.ply"
        path.write_bytes(trimesh.Trimesh(*_cube(), process=False).export(file_type="ply", encoding="ascii")
                         .replace(old, new, 1))
        return path
    return write


FACES_50 = (b"element face 12", b"element face 50")
VERTICES_20 = (b"element vertex 8", b"element vertex 20")
HELD_12 = "the header declares 50 face elements, the file ends after 12 of them"
VERTEX_BYTES = "the header declares 20 vertex and 12 face elements, at least 396 bytes; the file holds 252"
FACE_COLOURS = (("uchar", "red"), ("uchar", "green"), ("uchar", "blue"))

# (name, write(tmp) -> path, the words of the one line)
PLY_COUNT_CASES = [
    ("ascii faces", _ascii(*FACES_50), HELD_12),
    ("ascii vertices", _ascii(*VERTICES_20), "declares 20 vertex elements, the file ends after 8 of them"),
    ("binary le faces", _binary("<", *FACES_50), HELD_12),
    ("binary be faces", _binary(">", *FACES_50), HELD_12),
    ("binary le face colours", _binary("<", *FACES_50, extra_face=FACE_COLOURS), HELD_12),
    ("binary be quads", _binary(">", *FACES_50, counts=[4] * 12), HELD_12),
    ("binary le vertices", _binary("<", *VERTICES_20), VERTEX_BYTES),
    ("binary be vertices", _binary(">", *VERTICES_20), VERTEX_BYTES),
    ("binary mixed polygons", _binary("<", *FACES_50, counts=[3, 4] * 6),
     "the header declares 8 vertex and 50 face elements, at least"),
]


@pytest.mark.parametrize("name, write, words", PLY_COUNT_CASES, ids=[c[0] for c in PLY_COUNT_CASES])
def test_14_ply_declaring_more_than_it_holds(tmp_path, name, write, words):
    from raytrace.errors import RaytraceError
    from raytrace.scene.formats.mesh import read_mesh_parts
    path = write(tmp_path)
    with pytest.raises(RaytraceError) as info:
        read_mesh_parts(path)
    assert str(info.value).startswith(f"{path}: ") and words in str(info.value)


@pytest.mark.parametrize("name, write, _", PLY_COUNT_CASES[:1], ids=["cli"])
def test_14_ply_count_cli_one_line(tmp_path, name, write, _):
    write(tmp_path)
    p = subprocess.run([sys.executable, "-m", "raytrace", "m.ply", "-o", "x.png"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert (p.returncode, lines(p.stderr)) == (1, [f"Error: m.ply: {HELD_12}"])


@pytest.mark.parametrize("name, write", [
    ("ascii", _ascii(b"", b"")),
    ("binary face colours", _binary("<", b"", b"", extra_face=FACE_COLOURS)),
    ("binary mixed polygons", _binary(">", b"", b"", counts=[3, 4] * 6)),
])
def test_14_ply_holding_what_it_declares_reads(tmp_path, name, write):
    from raytrace.scene.formats.mesh import read_mesh_parts
    (part,) = read_mesh_parts(write(tmp_path))
    assert len(part.vertices) == 8 and len(part.faces) in (12, 18)


# --- 6: a --scheduler peer that does not speak Dask -------------------------

def _peer(answer):
    """A TCP server on 127.0.0.1 that answers each connection with
    ``answer(sock)``, in a thread: its address."""
    import socket
    import threading
    server = socket.create_server(("127.0.0.1", 0))

    def serve():
        while True:
            sock, _ = server.accept()
            threading.Thread(target=answer, args=(sock,), daemon=True).start()
    threading.Thread(target=serve, daemon=True).start()
    return f"tcp://127.0.0.1:{server.getsockname()[1]}"


def _http(sock):
    sock.recv(4096)        # Dask's handshake, read as a request: an HTTP server's answer
    sock.sendall(b"HTTP/1.0 400 Bad request\r\nContent-Type: text/html\r\n\r\n<html>400</html>\n")


def _garbage(sock):
    sock.sendall(b"\xff" * 64 + b"not dask\n" * 100)


def _silent(sock):
    sock.recv(4096)
    time.sleep(30)


def _closes(sock):
    sock.close()


def _refused():
    import socket
    with socket.create_server(("127.0.0.1", 0)) as s:
        return f"tcp://127.0.0.1:{s.getsockname()[1]}"       # closed again: nothing listens


def _http_server():
    """Python's own HTTP server (which waits for the rest of a request)."""
    import http.server
    import threading

    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"tcp://127.0.0.1:{server.server_address[1]}"


UNLIKE = "(is it a Dask scheduler's address?)"
# (name, address(), the words of the one line after the address)
PEER_CASES = [
    ("http.server", _http_server, f"no answer from {{}} in 1 s {UNLIKE}"),
    ("http answer", lambda: _peer(_http), f"answered with something other than Dask's handshake {UNLIKE}"),
    ("garbage bytes", lambda: _peer(_garbage), "answered with something other than Dask's handshake"),
    ("silent", lambda: _peer(_silent), f"no answer from {{}} in 1 s {UNLIKE}"),
    # Dask's connect gives a first attempt a fifth of its time (0.16 s here)
    # and retries with backoff: on a loaded machine (CI's test workers
    # compiling on 2 cores) the deadline can pass before the peer's close,
    # or a refusal, is seen, and Dask says so.
    ("closes", lambda: _peer(_closes), ("closed the connection before Dask's handshake",
                                        "cannot reach the Dask scheduler at {}: Timed out trying "
                                        "to connect")),
    ("refused", _refused, ("cannot reach the Dask scheduler at {}: Connection refused",
                           "cannot reach the Dask scheduler at {}: Timed out trying to connect")),
]


@pytest.mark.parametrize("name, address, words", PEER_CASES, ids=[c[0] for c in PEER_CASES])
def test_6_peer_not_speaking_dask_fails_in_time(name, address, words):
    pytest.importorskip("distributed")
    from raytrace.errors import RaytraceError
    from raytrace.frames.distributed import check_handshake
    address = address()
    t0 = time.monotonic()
    with pytest.raises(RaytraceError) as info:
        check_handshake(address, timeout=1)
    assert time.monotonic() - t0 < 3
    said = str(info.value)
    assert address in said and any(w.format(address) in said for w in
                                   ((words,) if isinstance(words, str) else words)), said


def test_6_cli_peer_not_speaking_dask_is_one_line(tmp_path):
    pytest.importorskip("distributed")
    address = _peer(_garbage)
    p = subprocess.run([sys.executable, "-m", "raytrace", "spheres", "--width", "16", "--height",
                        "12", "-o", "x.png", "--scheduler", address], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)
    got = [ln for ln in lines(p.stderr) if not ln.startswith("compiling kernels")]
    assert (p.returncode, got) == (1, [f"Error: {address} answered with something other than "
                                       f"Dask's handshake {UNLIKE}"])
    assert list(tmp_path.iterdir()) == []


# --- 7: memory planned: lazy fields in blocks, camera rays refused ---------

def _mixed_scene():
    """A mesh, a plane and a sphere, and rays that hit each and miss."""
    import numpy as np
    import trimesh

    from raytrace.cast.rayscene import RayScene
    from raytrace.scene.model import Camera, Material, Mesh, Plane, Scene, Sphere
    box = trimesh.creation.box()
    m = Material()
    scene = Scene("s", Camera((0, 0, 5), (0, 0, 0)), objects=[
        Mesh(np.asarray(box.vertices), np.asarray(box.faces), m), Plane((0, -1, 0), (0, 2, 0), m),
        Sphere((3, 0, 0), 1.0, m)])
    rng = np.random.default_rng(1)
    n = 1000
    origins = np.c_[rng.uniform(-5, 5, (n, 2)), np.full(n, 5.0)]
    directions = np.c_[rng.uniform(-0.3, 0.3, (n, 2)), -np.ones(n)]
    return RayScene(scene), origins, directions


LAZY_FIELDS = [
    ("cast_rays", lambda rs, o, d: rs.cast_rays(o, d), ("normal", "point", "geometry_id", "prim_id")),
    ("list_intersections", lambda rs, o, d: rs.list_intersections(o, d),
     ("normal", "point", "geometry_id", "prim_id")),
    ("closest_points", lambda rs, o, d: rs.closest_points(o + 5 * d), ("normal", "geometry_id", "prim_id")),
]


@pytest.mark.parametrize("name, query, fields", LAZY_FIELDS, ids=[c[0] for c in LAZY_FIELDS])
def test_7_lazy_fields_in_blocks_are_the_whole_answer(monkeypatch, name, query, fields):
    """Blocks of 7 rows give, bit for bit, the fields made in one block."""
    import numpy as np

    import raytrace.cast.prepared as prepared
    rs, o, d = _mixed_scene()
    whole = query(rs, o, d)
    want = {f: np.array(getattr(whole, f)) for f in fields}
    assert {0, 1, 2} <= set(want["geometry_id"].tolist())      # mesh, plane and sphere
    monkeypatch.setattr(prepared, "SURFACE_BLOCK", 7)
    blocked = query(rs, o, d)
    for f in fields:
        np.testing.assert_array_equal(getattr(blocked, f), want[f], err_msg=f)
        assert getattr(blocked, f).dtype == want[f].dtype, f


@pytest.mark.parametrize("field", ["normal", "point", "prim_id"])
def test_7_lazy_field_costs_its_answer_not_several(field):
    """Reading a field of many rays allocates about its own size (whole,
    normal took six times it)."""
    import tracemalloc

    import numpy as np

    import raytrace.cast.prepared as prepared
    from raytrace.cast.rayscene import RayScene
    n = 50 * prepared.SURFACE_BLOCK
    hits = RayScene(_cube()).cast_rays(np.tile([0.0, 0.0, 5.0], (n, 1)),
                                       np.tile([0.0, 0.0, -1.0], (n, 1)))
    tracemalloc.start()
    try:
        answer = getattr(hits, field)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    answers = 2 * answer.nbytes if field == "prim_id" else answer.nbytes   # ids come in pairs
    assert peak < answers + 64 * prepared.SURFACE_BLOCK * 8, (peak, answer.nbytes)


GIB = 1 << 30
# (name, free bytes, call, words or None if made)
RAY_MEMORY_CASES = [
    ("65536 squared", 64 * GIB, lambda r: r.create_rays_pinhole(60, [0, 0, 0], [0, 0, 5], [0, 1, 0],
                                                                 65536, 65536),
     "65536x65536 rays need about 448.0 GiB of memory while they are made, more than the 64.0 GiB "
     "available"),
    ("matrices", 1 * GIB, lambda r: r.create_rays_from_matrices([[100, 0, 50], [0, 100, 50], [0, 0, 1]],
                                                                 __import__("numpy").eye(4), 4096, 4096),
     "4096x4096 rays need about 1.8 GiB"),
    ("fits", 1 * GIB, lambda r: r.create_rays_pinhole(60, [0, 0, 0], [0, 0, 5], [0, 1, 0], 64, 48), None),
]


@pytest.mark.parametrize("name, free, call, words", RAY_MEMORY_CASES, ids=[c[0] for c in RAY_MEMORY_CASES])
def test_7_camera_rays_refused_before_allocating(monkeypatch, name, free, call, words):
    import raytrace
    import raytrace.scene.formats.mesh
    monkeypatch.setattr(raytrace.scene.formats.mesh, "available_memory", lambda: free)
    if words is None:
        assert call(raytrace).shape == (48, 64, 6)
        return
    with pytest.raises(raytrace.RaytraceError) as info:
        call(raytrace)
    assert words in str(info.value)


def _counting_camera_buffers(monkeypatch):
    import raytrace.frames.batch as batch
    made = []
    real = batch.camera_buffer
    monkeypatch.setattr(batch, "camera_buffer", lambda *a: made.append(1) or real(*a))
    return made


def test_7_tasks_are_made_as_they_are_taken(monkeypatch):
    """--turntable 100000 --tiles 65536: 6.5e9 tasks, counted without making
    them; the first ones cost one camera buffer, shared by the frame's bands."""
    import itertools

    import numpy as np

    import raytrace
    from raytrace.frames.batch import Tasks, bands
    from raytrace.renderer.driver import camera_buffer
    from raytrace.scene.animation import turntable
    made = _counting_camera_buffers(monkeypatch)
    camera = raytrace.load_scene("spheres").camera
    tasks = Tasks(turntable(camera, 100_000), range(100_000), bands(65536, 65536), 640, 65536)
    assert (len(tasks), tasks.tallest) == (100_000 * 8192, 8)      # bands of whole 8-row strips
    first = list(itertools.islice(tasks, 3))
    assert made == [1] and [t[1:] for t in first] == [(0, 0, 8), (0, 8, 16), (0, 16, 24)]
    # Small: the same tasks a list made up front held, skipped frames left out.
    cams = turntable(camera, 4)
    rows = bands(48, 3)
    want = [(camera_buffer(c, 64, 48), f, y0, y1) for f, c in enumerate(cams) if f != 2
            for y0, y1 in rows]
    got = list(Tasks(cams, [0, 1, 3], rows, 64, 48))
    assert len(got) == len(want) == 9
    for (a, *ra), (b, *rb) in zip(got, want):
        assert ra == rb and np.array_equal(a, b)


def test_7_render_frames_hands_the_runner_lazy_tasks(monkeypatch):
    """The runner is handed the tasks before any is made; it makes them."""
    import raytrace
    from raytrace.frames.batch import render_frames
    from raytrace.renderer.driver import RenderOptions
    from raytrace.scene.animation import turntable
    made = _counting_camera_buffers(monkeypatch)
    seen = []

    class FirstTask:
        workers = 1

        def run(self, payload, tasks):
            seen.append((len(tasks), len(made)))
            next(iter(tasks))
            seen.append(len(made))
            return iter(())

    scene = raytrace.load_scene("spheres", width=16, height=12)
    render_frames(scene, turntable(scene.camera, 100_000), RenderOptions(width=16, height=12),
                  FirstTask(), tiles=65536)
    assert seen == [(100_000 * 2, 0), 1]          # 12 rows: two bands of whole 8-row strips
