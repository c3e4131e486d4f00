"""Issue 45's root causes, one table each, so none comes back.  CLI cases
run the real command (`python -m raytrace`) and assert the exit code and
the one line it prints; most stop before rendering (a bad output path),
so they compile nothing."""
import subprocess
import sys
import warnings

import pytest

from raytrace.cli.messages import escape, warning_line, warnings_once

SMALL = ["--width", "16", "--height", "12"]
NO_DIR = "/nonexistent-dir/x.png"      # fails after loading, before any kernel compiles


def run(args, cwd, timeout=120, env=None):
    p = subprocess.run([sys.executable, "-m", "raytrace", *map(str, args)], cwd=cwd,
                       capture_output=True, text=True, timeout=timeout, env=env)
    return p.returncode, p.stdout, p.stderr


def lines(err):
    out = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert "Traceback" not in err, err
    return out


# --- 1: a library's warning during loading looped without end --------------

NAN_UV_PLY = """ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
property float u
property float v
element face 1
property list uchar int vertex_indices
end_header
0 0 0 nan nan
1 0 0 0 0
0 1 0 1 1
3 0 1 2
"""


def nan_uv_ply(tmp):
    p = tmp / "nan.ply"
    p.write_text(NAN_UV_PLY)
    return [p]


# (name, setup(tmp) -> args, the warning line's words)
WARNING_CASES = [
    ("ply nan uv, render", nan_uv_ply, "RuntimeWarning"),
    ("ply nan uv, compare", lambda t: ["compare", *nan_uv_ply(t)], "RuntimeWarning"),
]


@pytest.mark.parametrize("name, setup, words", WARNING_CASES, ids=[c[0] for c in WARNING_CASES])
def test_1_library_warning_is_one_line_once(tmp_path, name, setup, words):
    rc, _, err = run([*setup(tmp_path), *SMALL, "-o", NO_DIR], tmp_path, timeout=60)
    got = lines(err)
    assert rc == 1, err
    assert len(got) == 2 and got[0].startswith("warning: ") and words in got[0], got
    assert got[1].startswith("Error: ") and "does not exist" in got[1], got


def _library_warns(n):
    for i in range(n):
        warnings.warn("the same thing", RuntimeWarning, stacklevel=1)
        warnings.warn(f"line one\nline {i % 2}", UserWarning, stacklevel=1)


def test_1_warnings_once_shows_each_line_once_and_ends(capsys):
    from raytrace.errors import warn
    with warnings_once():
        _library_warns(10_000)
        warn("ours")
        warn("ours")
        with warnings_once():          # nested: the outer one's lines
            warn("ours")
            warnings.warn("the same thing", RuntimeWarning, stacklevel=1)
    err = capsys.readouterr().err.splitlines()
    assert err == ["warning: the same thing (RuntimeWarning)",
                   "warning: line one line 0 (UserWarning)",
                   "warning: line one line 1 (UserWarning)",
                   "warning: ours"], err


def test_1_a_warning_shown_as_warnings_once_ends_is_no_error():
    """--workers' cluster starts on another thread while the scene loads:
    a warning it raises as the loading's warnings_once ends reaches the
    handler it took from warnings.showwarning, which still shows it."""
    import io
    out = io.StringIO()
    with warnings_once(out):
        show = warnings.showwarning         # what the other thread holds
    show(UserWarning("late"), UserWarning, "f.py", 1)
    assert out.getvalue() == "warning: late (UserWarning)\n"


# --- 12: newlines in names split the one-line error -------------------------

@pytest.mark.parametrize("text, want", [
    ("plain", "plain"),
    ("a\nb", "a\\nb"),
    ("a\r\x00b", "a\\r\\x00b"),
    ("é ü \u2028", "é ü \\u2028"),
])
def test_12_escape(text, want):
    assert escape(text) == want


def test_12_warning_line_is_one_line():
    assert warning_line("two\nlines", UserWarning) == "warning: two lines (UserWarning)"


NEWLINE_CASES = [
    ("scene file name", lambda t: ["bad\nname.obj"], 1),
    ("-o", lambda t: ["spheres", "-o", "a\nb.xyz"], 2),
    ("-o dir", lambda t: ["spheres", "-o", "no\ndir/x.png"], 1),
    ("toml key", lambda t: [_toml(t, '[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n'
                                     '"bad\\nkey" = 1\n')], 1),
]


def _toml(tmp, text, name="s.toml"):
    p = tmp / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("name, setup, code", NEWLINE_CASES, ids=[c[0] for c in NEWLINE_CASES])
def test_12_newline_in_a_name_stays_one_line(tmp_path, name, setup, code):
    rc, _, err = run([*setup(tmp_path), *SMALL], tmp_path, timeout=60)
    got = lines(err)
    assert rc == code and len(got) == 1 and "\\n" in got[0], (rc, err)


# --- 3: SIGTERM and SIGHUP ended without a word and left temporary files ----

def _signal_when_writing(tmp_path, signum, output, extra):
    """Start a render into ``output`` (an older file already there), send
    ``signum`` once its temporary file exists: (exit code, stderr)."""
    import os
    import signal
    import time
    (tmp_path / output).write_bytes(b"old")
    p = subprocess.Popen([sys.executable, "-m", "raytrace", "teapot", "--width", "64",
                          "--height", "48", *extra, "-o", output], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: [signal.signal(s, signal.SIG_DFL)
                                             for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)])
    deadline = time.monotonic() + 400     # a cold kernel cache compiles first
    while not any(n.endswith(".tmp") for n in os.listdir(tmp_path)) and p.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    p.send_signal(signum)
    _, err = p.communicate(timeout=120)
    return p.returncode, err


# A GIF's temporary file appears once every frame is rendered, an MP4's at
# the first frame.
STOP_CASES = [
    ("SIGTERM gif", "SIGTERM", "t.gif", 400, 143, "terminated (SIGTERM): no animation written"),
    ("SIGHUP mp4", "SIGHUP", "t.mp4", 2000, 129, "hung up (SIGHUP): no animation written"),
    ("SIGTERM mp4", "SIGTERM", "t.mp4", 2000, 143, "terminated (SIGTERM): no animation written"),
]


@pytest.mark.parametrize("name, sig, output, frames, code, line", STOP_CASES,
                         ids=[c[0] for c in STOP_CASES])
def test_3_sigterm_and_sighup_end_like_ctrl_c(tmp_path, name, sig, output, frames, code, line):
    import signal
    rc, err = _signal_when_writing(tmp_path, getattr(signal, sig), output,
                                   ["--turntable", str(frames)])
    assert (rc, lines(err)) == (code, [line])
    assert sorted(p.name for p in tmp_path.iterdir()) == [output]     # no .tmp left
    assert (tmp_path / output).read_bytes() == b"old"                 # untouched


def test_3_sigterm_during_a_still(tmp_path):
    import signal
    import time
    p = subprocess.Popen([sys.executable, "-m", "raytrace", "teapot", "--width", "640",
                          "--height", "480", "--shadows", "soft", "--spp", "8", "-o", "t.png"],
                         cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
    time.sleep(1.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert (p.returncode, lines(err)) == (143, ["terminated (SIGTERM): no image written"])
    assert list(tmp_path.iterdir()) == []


# --- 4: a damaged or unwritable kernel cache crashed the command ------------

# Two small cached functions of one signature under raytrace's cache
# directory (jitconfig): cheap to compile, and their data files can be swapped.
CACHED = """
from raytrace.cli.messages import warnings_once

with warnings_once():
    import raytrace.kernels.jitconfig
    from numba import njit

    @njit(cache=raytrace.kernels.jitconfig.CACHING)
    def plus_one(x):
        return x + 1

    @njit(cache=raytrace.kernels.jitconfig.CACHING)
    def times_ten(x):
        return x * 10

    print(plus_one(4), times_ten(4), raytrace.kernels.jitconfig.CACHING)
"""


def _cached(tmp_path, cache, env_extra=()):
    """Run CACHED as tmp_path/cached.py (its path and time name its cache
    entries, so a copied cache is found by the same script)."""
    import os
    script = tmp_path / "cached.py"
    if not script.exists():
        script.write_text(CACHED)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), **dict(env_extra))
    p = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout.strip(), p.stderr


def _files(cache, suffix):
    return sorted(p for p in cache.rglob(f"*{suffix}") if "cached" in p.name)


def _truncate(files):
    files[0].write_bytes(files[0].read_bytes()[:40])


def _garbage(files):
    files[0].write_bytes(b"\x80\x04garbage, not a pickle")


def _empty(files):
    for f in files:
        f.write_bytes(b"")


def _directory(files):
    files[0].unlink()
    (files[0] / "inside").mkdir(parents=True)


def _swap(files):
    a, b = files[0].read_bytes(), files[1].read_bytes()
    files[0].write_bytes(b)
    files[1].write_bytes(a)


DAMAGE_CASES = [
    ("truncated nbc", ".nbc", _truncate),
    ("garbage nbi", ".nbi", _garbage),
    ("garbage nbc", ".nbc", _garbage),
    ("empty nbi", ".nbi", _empty),
    ("empty nbc", ".nbc", _empty),
    ("directory for nbc", ".nbc", _directory),
    ("directory for nbi", ".nbi", _directory),
    ("swapped nbc", ".nbc", _swap),
]


@pytest.fixture(scope="module")
def filled_cache(tmp_path_factory):
    """A cache holding the two functions, copied by each case."""
    tmp = tmp_path_factory.mktemp("filled")
    assert _cached(tmp, tmp / "cache") == (0, "5 40 True", "")
    return tmp


@pytest.mark.parametrize("name, suffix, damage", DAMAGE_CASES, ids=[c[0] for c in DAMAGE_CASES])
def test_4_damaged_cache_is_rebuilt_with_one_warning(tmp_path, filled_cache, name, suffix, damage):
    import shutil
    cache = tmp_path / "cache"
    shutil.copytree(filled_cache / "cache", cache)
    files = _files(cache, suffix)
    assert len(files) == 2, files
    damage(files)
    rc, out, err = _cached(filled_cache, cache)
    got = lines(err)
    assert (rc, out) == (0, "5 40 True"), err
    assert len(got) == 1 and got[0].startswith("warning: kernel cache ") and "damaged" in got[0], got
    assert _cached(filled_cache, cache) == (0, "5 40 True", "")      # rebuilt: loads quietly


UNWRITABLE_CASES = [
    ("cache dir under a file", lambda t: {"NUMBA_CACHE_DIR": str(t / "file" / "cache")}),
    ("no home", lambda t: {"NUMBA_CACHE_DIR": "", "XDG_CACHE_HOME": "", "HOME": str(t / "file")}),
]


@pytest.mark.parametrize("name, env", UNWRITABLE_CASES, ids=[c[0] for c in UNWRITABLE_CASES])
def test_4_unwritable_cache_runs_uncached_with_one_warning(tmp_path, name, env):
    import os
    (tmp_path / "file").write_text("")
    script = tmp_path / "cached.py"
    script.write_text(CACHED)
    env = {k: v for k, v in dict(os.environ, **env(tmp_path)).items() if v != ""}
    p = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)
    got = lines(p.stderr)
    assert (p.returncode, p.stdout.strip()) == (0, "5 40 False"), p.stderr
    assert len(got) == 1 and "cannot write" in got[0] and "without a cache" in got[0], got


# --- 5: a scene file's name chose where its image went ----------------------

CAMERA = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = 16\nheight = 12\n"

NAME_CASES = [
    ("absolute", '"/tmp/x/ESCAPED"', "without a directory"),
    ("parent", '"../ESC2"', "without a directory"),
    ("backslash", '"..\\\\ESC3"', "without a directory"),
    ("nul", '"a\\u0000b"', "control characters, got 'a\\x00b'"),
    ("newline", '"a\\nb"', "control characters, got 'a\\nb'"),
    ("empty", '""', "plain file name, got ''"),
    ("dot dot", '".."', "plain file name, got '..'"),
    ("too long", '"' + "x" * 300 + '"', "longer than 200 bytes"),
]


@pytest.mark.parametrize("name, value, words", NAME_CASES, ids=[c[0] for c in NAME_CASES])
def test_5_scene_name_must_be_a_plain_file_name(tmp_path, name, value, words):
    from tests.conftest import scene_file_error
    path = _toml(tmp_path, f"name = {value}\n{CAMERA}")
    msg = scene_file_error(path)
    assert msg.startswith(f"{path}: name: ") and words in msg, msg


def test_5_a_plain_name_still_names_the_image():
    import pathlib
    import tempfile

    from raytrace.scene.formats.scenefile import read_scene_file
    with tempfile.TemporaryDirectory() as d:
        path = _toml(pathlib.Path(d), f'name = "village é"\n{CAMERA}')
        assert read_scene_file(path).name == "village é"


def test_5_cli_writes_nothing_outside_the_working_directory(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    path = _toml(work, f'name = "../ESC2"\n{CAMERA}')
    rc, _, err = run([path, "-q"], work, timeout=60)
    assert rc == 1 and lines(err) == [f"Error: {path}: name: must be a plain file name, without "
                                      "a directory, got '../ESC2'"]
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["s.toml", "work"]


# --- 10: giant integers and number formatting in scene-file messages --------

BIG = "1" + "0" * 400
NUMBER_CASES = [
    ("400-digit width", f"{CAMERA}width = {BIG}\n".replace("width = 16\n", ""),
     "camera.width: must be between 1 and 1048576, got an integer of about 401 digits"),
    ("400-digit radius", f'{CAMERA}[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = {BIG}\n',
     "objects[0].radius: beyond 1e+100, got an integer of about 401 digits"),
    ("5000-digit width", f"{CAMERA}width = 1{'0' * 5000}\n".replace("width = 16\n", ""),
     "a number too long to read"),
    ("range in full", f"{CAMERA}width = 10000000\n".replace("width = 16\n", ""),
     "camera.width: must be between 1 and 1048576, got 10000000"),
]


@pytest.mark.parametrize("name, text, words", NUMBER_CASES, ids=[c[0] for c in NUMBER_CASES])
def test_10_scene_numbers_in_messages(tmp_path, name, text, words):
    from tests.conftest import scene_file_error
    msg = scene_file_error(_toml(tmp_path, text))
    assert words in msg, msg


@pytest.mark.parametrize("value, shown", [(1048576, "1048576"), (1e7, "10000000"), (0.5, "0.5"),
                                          (1e200, "1e+200"), (10 ** 20, "100000000000000000000"),
                                          (10 ** 30, "an integer of about 31 digits"),
                                          (10 ** 400, "an integer of about 401 digits")])
def test_10_shown_number(value, shown):
    from raytrace.scene.formats.fields import shown_number
    assert shown_number(value) == shown


# --- 14: minor: byte-order marks ---------------------------------------------

def test_14_toml_with_a_bom_reads(tmp_path):
    from raytrace.scene.formats.scenefile import read_scene_file
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + f'name = "bom"\n{CAMERA}'.encode())
    assert read_scene_file(path).name == "bom"


# --- 14: minor ones: BOM in an OBJ, PLY counts, %%, "", --threads ------------

def _bom_obj(tmp):
    p = tmp / "bom.obj"
    p.write_bytes(b"\xef\xbb\xbfv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return [p]


def _short_ply(tmp):
    p = tmp / "faces.ply"
    p.write_text(NAN_UV_PLY.replace("element face 1", "element face 50").replace("nan nan", "0 0"))
    return [p]


# (name, setup -> args, exit code, the one line, or its words)
MINOR_CASES = [
    ("obj with a BOM reads", _bom_obj, 1, "Error: /nonexistent-dir/x.png: directory"),
    ("ply face count", _short_ply, 1, "faces.ply: the header declares 50 face elements, the file "
                                      "ends after 1 of them"),
    ("empty scene name", lambda t: [""], 2, "Error: empty scene name"),
    ("--threads named", lambda t: ["spheres", "--threads", "1000"], 2,
     "Error: --threads: threads must be between 1 and"),
    ("--threads named, frames", lambda t: ["spheres", "--turntable", "2", "--threads", "1000",
                                           "-o", "f.gif"], 2, "Error: --threads: threads must be"),
    ("%% is a literal %", lambda t: ["spheres", "--turntable", "2", "-o", "f_%%d.png"], 2,
     "f_%%d.png writes one image"),
]


@pytest.mark.parametrize("name, setup, code, words", MINOR_CASES, ids=[c[0] for c in MINOR_CASES])
def test_14_minor(tmp_path, name, setup, code, words):
    args = setup(tmp_path)
    if "-o" not in args:
        args = [*args, "-o", NO_DIR]
    rc, _, err = run([*args, *SMALL], tmp_path, timeout=60)
    got = lines(err)
    assert rc == code and len(got) == 1 and words in got[0], (rc, err)


@pytest.mark.parametrize("pattern, i, path", [
    ("f_%04d.png", 7, "f_0007.png"),
    ("f_%%_%d.png", 3, "f_%_3.png"),
    ("50%/f_%d.png", 2, "50%/f_2.png"),
])
def test_14_frame_path_percent(pattern, i, path):
    from raytrace.frames.writers import frame_path
    assert str(frame_path(pattern, i)) == path


def test_14_read_only_later_frame_refused_before_frame_0(tmp_path):
    (tmp_path / "fr").mkdir()
    late = tmp_path / "fr" / "f_2.png"
    late.write_bytes(b"old")
    late.chmod(0o444)
    rc, _, err = run(["spheres", *SMALL, "--turntable", "3", "-o", "fr/f_%d.png"], tmp_path)
    assert rc == 1 and lines(err) == ["Error: fr/f_2.png: read-only; left as it is"]
    assert sorted(p.name for p in (tmp_path / "fr").iterdir()) == ["f_2.png"]


# --- 9: --resume kept any file it found --------------------------------------

def test_9_resume_renders_damaged_frames_again(tmp_path):
    from PIL import Image
    args = ["spheres", *SMALL, "--turntable", "4", "-o", "f_%d.png", "-q"]
    assert run(args, tmp_path)[0] == 0
    good = (tmp_path / "f_0.png").read_bytes()
    (tmp_path / "f_1.png").write_bytes(b"")
    (tmp_path / "f_2.png").write_bytes(b"garbage")
    Image.new("RGB", (8, 6)).save(tmp_path / "f_3.png")          # another size
    rc, _, err = run([*args[:-1], "--resume", "--json"], tmp_path)
    assert rc == 0 and lines(err) == ["warning: --resume: 3 frame file(s) are not whole 16x12 PNGs "
                                      "(first: f_1.png); rendering them again"], err
    for i in range(4):
        with Image.open(tmp_path / f"f_{i}.png") as im:
            assert im.size == (16, 12)
    assert (tmp_path / "f_0.png").read_bytes() == good


# --- 8: a map_Kd naming a FIFO hung the load --------------------------------

@pytest.mark.parametrize("line", ["map_Kd tex.png", "map_Kd -s 1 1 1 tex.png"])
def test_8_texture_fifo_is_refused(tmp_path, line):
    import os
    os.mkfifo(tmp_path / "tex.png")
    (tmp_path / "t.mtl").write_text(f"newmtl m\n{line}\n")
    (tmp_path / "t.obj").write_text("mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\n"
                                    "vt 0 1\nusemtl m\nf 1/1 2/2 3/3\n")
    rc, _, err = run(["t.obj", *SMALL, "-o", NO_DIR], tmp_path, timeout=60)
    assert rc == 1 and lines(err) == ["Error: t.mtl: material 'm': map_kd tex.png: not a regular "
                                      "file (a FIFO, socket or device cannot be read)"], err


# --- 6: a bad --scheduler address was a traceback, after loading ------------

BAD_ADDRESSES = [
    ("garbage", "expected HOST:PORT"),
    ("tcp://", "expected HOST:PORT"),
    ("foo://1.2.3.4:1", "unknown transport 'foo://'"),
    ("inproc://x", "unknown transport 'inproc://'"),
    ("tcp://[::1", "expected [IPV6]:PORT"),
    ("tcp://[zz]:1", "'zz' is not an IPv6 address"),
    ("tcp://host:99999", "the port must be a number from 1 to 65535, got '99999'"),
    ("tcp://host:x", "the port must be a number"),
    ("tcp://:8786", "expected a host name"),
    ("tcp://a b:8786", "expected a host name"),
]


@pytest.mark.parametrize("address, words", BAD_ADDRESSES, ids=[a for a, _ in BAD_ADDRESSES])
def test_6_bad_scheduler_address_refused(address, words):
    from raytrace.errors import OptionError
    from raytrace.frames.dask_address import check_scheduler_address
    with pytest.raises(OptionError) as info:
        check_scheduler_address(address)
    assert words in str(info.value)


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "localhost:8786", "tls://[::1]:8786",
                                     "ws://host.example:80"])
def test_6_good_scheduler_address_kept(address):
    from raytrace.frames.dask_address import check_scheduler_address
    assert check_scheduler_address(address) == address


def test_6_cli_refuses_before_loading(tmp_path):
    rc, _, err = run(["spheres", *SMALL, "--scheduler", "inproc://x"], tmp_path, timeout=60)
    assert rc == 2 and lines(err) == ["Error: --scheduler: scheduler address 'inproc://x': unknown "
                                      "transport 'inproc://' (use tcp://, tls://, ws://, wss://, ucx://)"]


# --- 11: API arguments: numpy scalars accepted, bad ones a RaytraceError ----

def _spheres():
    import raytrace
    return raytrace.load_scene("spheres", width=16, height=12)


def _np(name):
    import numpy as np
    return getattr(np, name)


API_REFUSED = [
    ("render tiles=0", lambda r: r.render(_spheres(), tiles=0), "tiles must be an integer"),
    ("render tiles='2'", lambda r: r.render(_spheres(), tiles="2"), "tiles must be an integer"),
    ("render client=str", lambda r: r.render(_spheres(), client="tcp://x"),
     "client: expected a dask.distributed Client, got str"),
    ("render_frames cameras=[None]", lambda r: r.render_frames(_spheres(), cameras=[None]),
     "cameras[0]: expected a Camera, got NoneType"),
    ("render_frames progress='x'", lambda r: r.render_frames(_spheres(), turntable=2, progress="x"),
     "progress must be a function"),
    ("load_scene detail=5.5", lambda r: r.load_scene("teapot", detail=5.5), "detail must be an integer"),
    ("load_scene fov complex", lambda r: r.load_scene("spheres", fov=40 + 1j), "fov must be a finite number"),
]


@pytest.mark.parametrize("name, call, words", API_REFUSED, ids=[c[0] for c in API_REFUSED])
def test_11_api_refuses_with_raytrace_error(name, call, words):
    import raytrace
    with pytest.raises(raytrace.RaytraceError) as info:
        call(raytrace)
    assert words in str(info.value)


API_ACCEPTED = [
    ("detail np.int64", lambda r: r.load_scene("teapot", detail=_np("int64")(5)),
     lambda s: s.objects[0].__class__.__name__ != ""),
    ("fov np.float32", lambda r: r.load_scene("spheres", fov=_np("float32")(40)),
     lambda s: type(s.camera.fov) is float and s.camera.fov == 40.0),
    ("width np.int64", lambda r: r.load_scene("spheres", width=_np("int64")(16)),
     lambda s: type(s.camera.width) is int and s.camera.width == 16),
]


@pytest.mark.parametrize("name, call, check", API_ACCEPTED, ids=[c[0] for c in API_ACCEPTED])
def test_11_api_accepts_numpy_scalars(name, call, check):
    import raytrace
    assert check(call(raytrace))


# --- 7 (part): long jobs' memory planned before they start -------------------

GIB = 1 << 30


def _long_gif(t):
    from raytrace.frames.writers import frame_output
    return frame_output(t / "t.gif", 10_000, size=(640, 480))


def _workers(n):
    from raytrace.frames.distributed import check_worker_count
    return lambda t: check_worker_count(n)


MEMORY_CASES = [
    # (name, free bytes, call(tmp) , words or None if accepted)
    ("gif too long", 1 * GIB,
     _long_gif,
     "10,000 GIF frames of 640x480 are kept until the end, about 2.9 GiB, more than the 1.0 GiB free"),
    ("gif that fits", 4 * GIB,
     _long_gif,
     None),
    ("workers too many", 4 * GIB,
     _workers(64),
     "64 workers need about 16.0 GiB; this machine has 4.0 GiB free, enough for 16"),
    ("workers that fit", 4 * GIB,
     _workers(16), None),
]


@pytest.mark.parametrize("name, free, call, words", MEMORY_CASES, ids=[c[0] for c in MEMORY_CASES])
def test_7_memory_planned_up_front(tmp_path, monkeypatch, name, free, call, words):
    import raytrace.scene.formats.mesh
    from raytrace.errors import RaytraceError
    monkeypatch.setattr(raytrace.scene.formats.mesh, "available_memory", lambda: free)
    if words is None:
        call(tmp_path)
        return
    with pytest.raises(RaytraceError) as info:
        call(tmp_path)
    assert words in str(info.value)
