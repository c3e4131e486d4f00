"""Issue 18's defects, one case each, so none comes back: special files,
OS errors, interrupted writes, values past the limits, exit codes, and the
API's exceptions.  Each CLI case runs the real `raytrace` command line
(raytrace.cli.main.entry) and asserts exit code, a one-line message, and that
no output was written or replaced."""
import errno
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import raytrace
from raytrace import RaytraceError

OLD = b"the previous image"
SMALL = ["--width", "16", "--height", "12"]
TETRA_DEGENERATE = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"


def run(args, cwd, timeout=120):
    """`python -m raytrace ARGS`: (exit code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "raytrace", *map(str, args)], cwd=cwd,
                       capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def one_line(err):
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def nested_toml(tmp):
    p = tmp / "deep.toml"
    p.write_text("x = " + "[" * 1000 + "]" * 1000 + "\n")
    return p


def fifo(tmp, name):
    p = tmp / name
    os.mkfifo(p)
    return p


def sparse(tmp, name, size=100 << 30):
    p = tmp / name
    with open(p, "wb") as fh:
        fh.truncate(size)
    return p


def degenerate_obj(tmp):
    p = tmp / "flat.obj"
    p.write_text(TETRA_DEGENERATE)
    return p


def vertices_only_obj(tmp):
    p = tmp / "points.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    return p


def scene_with(tmp, extra, camera='position = [0, 0, 5]\nlook_at = [0, 0, 0]\n'):
    p = tmp / "s.toml"
    p.write_text("[camera]\n" + camera + extra)
    return p


LONG = "x" * 300

# (name, setup(tmp) -> args, exit code, words in the one line)
CASES = [
    ("1 fifo mesh", lambda t: [fifo(t, "p.obj"), *SMALL], 1, "not a regular file"),
    ("1 fifo scene", lambda t: [fifo(t, "p.toml"), *SMALL], 1, "not a regular file"),
    ("2 nested toml", lambda t: [nested_toml(t), *SMALL], 1, "nested too deeply"),
    ("3 output in /proc", lambda t: ["spheres", *SMALL, "-o", "/proc/x.png"], 1, "cannot write"),
    ("3 long output name", lambda t: ["spheres", *SMALL, "-o", LONG + ".png"], 1, "longer than 255 bytes"),
    ("3 long heatmap name", lambda t: ["spheres", *SMALL, "--heatmap", LONG + ".png"], 1,
     "longer than 255 bytes"),
    ("3 long mesh name", lambda t: [LONG + ".obj", *SMALL], 1, "cannot read"),
    ("3 long scene name", lambda t: [LONG + ".toml", *SMALL], 1, "cannot read"),
    ("8 degenerate mesh", lambda t: [degenerate_obj(t), *SMALL], 1, "no non-degenerate triangles"),
    ("8 vertices only", lambda t: [vertices_only_obj(t), *SMALL], 1, "no non-degenerate triangles"),
    ("9 width", lambda t: ["spheres", "--width", "1000000000000"], 2, "--width"),
    ("9 threads", lambda t: ["spheres", *SMALL, "--threads", "999"], 2, "threads must be between 1"),
    ("9 seed", lambda t: ["spheres", *SMALL, "--seed", str(2 ** 70)], 2, "--seed"),
    ("9 light samples", lambda t: ["spheres", *SMALL, "--light-samples", "1000000000"], 2,
     "--light-samples"),
    ("9 non-square samples", lambda t: ["spheres", *SMALL, "--light-samples", "2", "--shadows", "soft"],
     2, "square number"),
    ("9 fov nan", lambda t: ["spheres", *SMALL, "--fov", "nan"], 2, "not a finite number"),
    ("9+10 view inf", lambda t: [degenerate_obj(t), *SMALL, "--view", "inf,0"], 2, "got 'inf'"),
    ("11 empty output", lambda t: ["spheres", *SMALL, "-o", ""], 2, "empty file name"),
    ("12 camera up", lambda t: [scene_with(t, "up = [0, 0, 1]\n"), *SMALL], 1, "s.toml: camera.up: parallel"),
    ("12 plane normal", lambda t: [scene_with(t, '[[objects]]\ntype = "plane"\nnormal = [0, 1e-320, 0]\n'),
                                   *SMALL], 1, "s.toml: objects[0].normal: too short"),
    ("12 light samples", lambda t: [scene_with(t, '[[lights]]\ntype = "area"\nposition = [0, 3, 0]\n'
                                                  'size = 1\nsamples = 2\n'), *SMALL, "--shadows", "soft"],
     1, "s.toml: lights[0].samples"),
    ("13 huge obj", lambda t: [sparse(t, "big.obj"), *SMALL], 1, "GiB is more than"),
    ("13 huge toml", lambda t: [sparse(t, "big.toml"), *SMALL], 1, "GiB is more than"),
    ("13 huge ply", lambda t: [sparse(t, "big.ply"), *SMALL], 1, "GiB is more than"),
    ("minor jpg unknown", lambda t: ["spheres", *SMALL, "-o", "x.xyz"], 2, "unknown image format"),
]


@pytest.mark.parametrize("name, setup, code, words", CASES, ids=[c[0] for c in CASES])
def test_cli_defect(tmp_path, name, setup, code, words):
    keep = tmp_path / "spheres.png"
    keep.write_bytes(OLD)
    args = setup(tmp_path)
    rc, out, err = run(args, tmp_path, timeout=60)
    assert rc == code, (rc, out, err)
    line = one_line(err)
    assert line.startswith("Error: ") and words in line, line
    assert keep.read_bytes() == OLD
    made = sorted(p.name for p in tmp_path.iterdir() if p.suffix in (".png", ".npz", ".tmp", ".probe"))
    assert made == ["spheres.png"], made


def test_4_a_device_is_never_replaced(tmp_path):
    import stat
    rc, _, err = run(["spheres", *SMALL, "-o", "/dev/null"], tmp_path)
    assert rc == 2 and "unknown image format" in one_line(err)    # no extension: refused first
    dev = tmp_path / "dev.png"
    dev.symlink_to("/dev/null")            # an image name that is a device underneath
    rc, _, err = run(["spheres", *SMALL, "-o", dev], tmp_path)
    assert rc == 1 and "not a regular file" in one_line(err)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode) and dev.is_symlink()


def test_4_symlinked_and_read_only_outputs(tmp_path):
    real = tmp_path / "real.png"
    real.write_bytes(OLD)
    link = tmp_path / "link.png"
    link.symlink_to(real)
    rc, _, err = run(["spheres", *SMALL, "-o", link, "-q"], tmp_path)
    assert rc == 0, err
    assert link.is_symlink() and real.read_bytes()[:4] == b"\x89PNG"   # written through the link
    ro = tmp_path / "ro.png"
    ro.write_bytes(OLD)
    ro.chmod(0o444)
    rc, _, err = run(["spheres", *SMALL, "-o", ro], tmp_path)
    assert rc == 1 and "read-only" in one_line(err)     # even for root: the mode says so
    assert ro.read_bytes() == OLD


def test_5_outputs_are_committed_together(tmp_path, monkeypatch):
    """An interruption while the outputs are written replaces none of them."""
    from click.testing import CliRunner

    from raytrace.cli import main as cli
    from raytrace.renderer import output
    out = tmp_path / "out.png"
    out.write_bytes(OLD)
    calls = []
    real_npz = output.npz_writer

    def npz_then_interrupt(arrays):
        calls.append(1)

        def write(fh):
            real_npz(arrays)(fh)
            raise KeyboardInterrupt
        return write
    monkeypatch.setattr(output, "npz_writer", npz_then_interrupt)
    r = CliRunner().invoke(cli.main, ["spheres", *SMALL, "-o", str(out), "--aov", "depth",
                                      "--heatmap", str(tmp_path / "h.png")])
    assert calls and r.exit_code == 130 and "interrupted: no image written" in r.output
    assert out.read_bytes() == OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]


def test_3_full_disk_is_one_line_and_no_file(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from raytrace.cli import main as cli
    from raytrace.renderer import output

    def no_space(image, path):
        def write(fh):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return write
    monkeypatch.setattr(output, "image_writer", no_space)
    r = CliRunner().invoke(cli.main, ["spheres", *SMALL, "-o", str(tmp_path / "x.png")])
    assert r.exit_code == 1 and "No space left on device" in r.output
    assert list(tmp_path.iterdir()) == []


def test_minor_jpg_is_jpeg_and_scene_name_names_the_output(tmp_path):
    from PIL import Image
    rc, _, err = run(["spheres", *SMALL, "-o", "x.jpg", "-q"], tmp_path)
    assert rc == 0, err
    assert Image.open(tmp_path / "x.jpg").format == "JPEG"
    scene = scene_with(tmp_path, "", camera='position = [0, 0, 5]\nlook_at = [0, 0, 0]\n')
    scene.write_text('name = "village"\n' + scene.read_text())
    rc, _, err = run([scene, *SMALL, "-q"], tmp_path)
    assert rc == 0, err
    assert (tmp_path / "village.png").exists()


@pytest.mark.parametrize("delay", [0.25, 0.6, 1.5])
def test_16_ctrl_c_at_any_moment_is_130_and_one_line(tmp_path, delay):
    """From the moment Python runs raytrace's code (python's own start-up,
    ~50 ms, is not ours to handle) to the end of the render."""
    # A render of several seconds (soft shadows, 8 samples a pixel), so the
    # signal lands before its end.
    p = subprocess.Popen([sys.executable, "-m", "raytrace", "teapot", "--width", "640",
                          "--height", "480", "--shadows", "soft", "--spp", "8", "-o", "t.png"],
                         cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         # A job started in the background by a shell (as CI may
                         # be) inherits SIGINT ignored, and Python keeps it so.
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, (p.returncode, err)
    assert one_line(err) == "interrupted: no image written"
    assert not (tmp_path / "t.png").exists()


def _command(tmp_path, prelude):
    """Run raytrace.cli.command.main in a new process after `prelude`: (exit code, stderr)."""
    code = prelude + ("\nimport sys\nfrom raytrace.cli import command\n"
                      "sys.argv = ['raytrace', 'spheres', '--width', '8', '--height', '6', "
                      "'-o', 'x.png']\ncommand.main()\n")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120)
    return p.returncode, p.stderr


def _ended(tmp_path, prelude, args):
    """Run raytrace.cli.command.main with ``args`` after ``prelude``, then a
    line the process should never reach: (exit code, stdout, stderr)."""
    code = (prelude + "\nimport sys\nfrom raytrace.cli import command\n"
            f"sys.argv = ['raytrace', *{args!r}]\ncommand.main()\n"
            "sys.stderr.write('after main\\n')\n")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr


HANDLER = "import atexit, sys\natexit.register(lambda: sys.stderr.write('handler ran\\n'))"


def test_the_command_ends_with_its_code_after_the_exit_handlers(tmp_path):
    """The command ends its process itself (cli/command.py _end, skipping
    Python's teardown): exit handlers still run, the output is all there
    (the JSON parses) and the exit code is the command's."""
    import json
    rc, out, err = _ended(tmp_path, HANDLER, ["spheres", "--width", "8", "--height", "6",
                                              "-o", "x.png", "--json", "-q"])
    assert rc == 0, err
    assert json.loads(out)["triangles"] >= 0
    assert "handler ran" in err and "after main" not in err
    assert (tmp_path / "x.png").stat().st_size > 0
    rc, out, err = _ended(tmp_path, HANDLER, ["no_such_scene"])
    assert rc == 2
    assert "handler ran" in err and "after main" not in err
    assert err.splitlines()[0].startswith("Error: unknown scene 'no_such_scene'")


def test_the_command_waits_for_a_thread_that_is_not_a_daemon(tmp_path):
    """A thread the caller started and did not make a daemon still finishes:
    the command then exits as Python does, after it."""
    rc, _, err = _ended(tmp_path, "import sys, threading, time\n"
                                  "threading.Thread(target=lambda: (time.sleep(0.5), "
                                  "sys.stderr.write('thread done\\n'))).start()",
                        ["spheres", "--width", "8", "--height", "6", "-o", "x.png", "-q"])
    assert rc == 0, err
    assert "thread done" in err


def test_16_ctrl_c_inside_exec_code_is_still_130(tmp_path):
    """A Ctrl-C that lands in exec()'d code (a namedtuple or dataclass being
    made while a module loads) makes CPython 3.11 kill itself with SIGINT at
    exit, whatever sys.exit said: seen as -2 one run in 150 of test_16."""
    rc, err = _command(tmp_path, "import raytrace.cli.main as cli\n"
                                 "cli.entry = lambda: exec('raise KeyboardInterrupt')")
    assert rc == 130, (rc, err)
    assert one_line(err) == "interrupted: no image written"


def test_16_ctrl_c_python_dropped_still_stops_the_render(tmp_path):
    """A Ctrl-C raised in a weakref callback is printed as "Exception ignored"
    and dropped; the command still stops with 130 before it writes."""
    rc, err = _command(tmp_path, "import gc, weakref\n"
                                 "class Part: pass\n"
                                 "part = Part()\n"
                                 "from raytrace.renderer import interrupt\n"
                                 "def signal_lands_here(ref):\n"
                                 "    interrupt.on_sigint(2, None)\n"
                                 "ref = weakref.ref(part, signal_lands_here)\n"
                                 "import signal, sys\n"
                                 "signal.signal(signal.SIGINT, interrupt.on_sigint)\n"
                                 "sys.unraisablehook = interrupt.unraisable\n"
                                 "del part\n")
    assert rc == 130, (rc, err)
    assert one_line(err) == "interrupted: no image written"
    assert not (tmp_path / "x.png").exists()


def test_16_a_ctrl_c_a_c_extension_prints_while_importing_stays_quiet(tmp_path):
    """A Ctrl-C that lands while a C extension imports (NumPy's import_array
    in Numba's extensions) is printed by it with PyErr_Print, and the import
    fails with an ImportError: the command still says one line."""
    rc, err = _command(tmp_path, "import raytrace.cli.main as cli\n"
                                 "def entry():\n"
                                 "    import ctypes\n"
                                 "    from raytrace.renderer import interrupt\n"
                                 "    try:\n"
                                 "        interrupt.on_sigint(2, None)\n"
                                 "    except KeyboardInterrupt:\n"
                                 # C code that prints the error it meets (PyErr_Print)
                                 "        ctypes.pythonapi.PyRun_SimpleString(b'raise KeyboardInterrupt')\n"
                                 "    raise ImportError('numpy._core.multiarray failed to import')\n"
                                 "cli.entry = entry\n")
    assert rc == 130, (rc, err)
    assert one_line(err) == "interrupted: no image written"


def test_16_errors_a_ctrl_c_leaves_in_library_callbacks_stay_quiet(tmp_path):
    """A callback the Ctrl-C cut short leaves its library's state broken and
    the next call of it fails (distributed's GC timer asserts): once the
    command is stopping, such "Exception ignored" errors are not printed."""
    rc, err = _command(tmp_path, "import weakref\n"
                                 "class Part: pass\n"
                                 "first, second = Part(), Part()\n"
                                 "from raytrace.renderer import interrupt\n"
                                 "def signal_lands_here(ref):\n"
                                 "    interrupt.on_sigint(2, None)\n"
                                 "def state_was_cut_short(ref):\n"
                                 "    assert False, 'timer already running'\n"
                                 "refs = [weakref.ref(first, signal_lands_here),\n"
                                 "        weakref.ref(second, state_was_cut_short)]\n"
                                 "import signal, sys\n"
                                 "signal.signal(signal.SIGINT, interrupt.on_sigint)\n"
                                 "sys.unraisablehook = interrupt.unraisable\n"
                                 "del first\n"
                                 "del second\n")
    assert rc == 130, (rc, err)
    assert one_line(err) == "interrupted: no image written"


@pytest.mark.parametrize("call, words", [
    (lambda: raytrace.cast_rays((np.eye(3), [[0, 1, 2], [0, 1]]), [[0, 0, 1.0]], [[0, 0, -1.0]]),
     "faces"),
    (lambda: raytrace.cast_rays((np.eye(3), [[0, 1, 2]]), [[0, 0, 1.0], [0, 0]], [[0, 0, -1.0]]),
     "origins"),
    (lambda: raytrace.cast_rays((np.eye(3), [[0, 1, 2]]), [[0, 0, 1.0]], [[0, 0, -1.0]],
                                accel=["bvh"]), "acceleration structure"),
    (lambda: raytrace.render("spheres", accel=["bvh"], width=8, height=6), "acceleration structure"),
    (lambda: raytrace.load_scene("spheres", width="abc"), "width"),
    (lambda: raytrace.load_scene("spheres", height=0), "height"),
    (lambda: raytrace.load_scene("spheres", fov="abc"), "fov"),
    (lambda: raytrace.load_scene(str(_house()), azimuth="abc"), "azimuth"),
    (lambda: raytrace.load_scene(str(_house()), azimuth=float("nan")), "got nan"),
    (lambda: raytrace.render(None), "expected a Scene"),
    (lambda: raytrace.render(123), "expected a Scene"),
    (lambda: raytrace.render("spheres", progress=5, width=8, height=6), "progress"),
    (lambda: raytrace.render(_no_camera()), "no camera"),
    (lambda: raytrace.render("spheres", frobnicate=1), "frobnicate"),
])
def test_14_api_raises_raytrace_error_naming_the_argument(call, words):
    with pytest.raises(RaytraceError, match=words):
        call()


def _house():
    from raytrace.scene.assets import assets_dir
    return assets_dir() / "house.obj"


def _no_camera():
    sc = raytrace.load_scene("spheres")
    sc.camera = None
    return sc


def test_6_the_whole_coordinate_range_works():
    """Near the documented 1e100 limit normals were squares that overflowed
    to zero (a flat grey render) and cast_rays warned of overflow."""
    import warnings

    from raytrace.scene.model import Camera, Light, Mesh, Scene
    for s in (1e90, 2e99):        # camera and rays at 3 s: within the 1e100 limit
        v = np.array([[1, 0, -1 / np.sqrt(2)], [-1, 0, -1 / np.sqrt(2)],
                      [0, 1, 1 / np.sqrt(2)], [0, -1, 1 / np.sqrt(2)]]) * s
        f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            h = raytrace.cast_rays((v, f), [[0.1 * s, 0.05 * s, 3 * s]], [[0, 0, -1.0]])
            assert h.hit[0] and np.isclose(np.linalg.norm(h.normal[0]), 1.0)
            sc = Scene("tetra", Camera((2 * s, 1.5 * s, 3 * s), (0, 0, 0), width=24, height=18),
                       objects=[Mesh(v, f)], lights=[Light((3 * s, 5 * s, 4 * s))])
            r = raytrace.render(sc, aov=True)
        n = r.aovs["normal"][r.aovs["primid"] >= 0]
        assert len(n) and np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
        assert len(np.unique(r.image.reshape(-1, 3), axis=0)) > 3    # faces shaded apart


@pytest.mark.parametrize("extra, words", [
    ('[[objects]]\ntype = "teapot"\nscale = 1e300\n', "objects[0].scale: beyond 1e+100"),
    ('[[objects]]\ntype = "teapot"\nscale = 1e100\n', "objects[0].scale: translate, rotate and scale"),
    ('[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = 1e300\n',
     "objects[0].radius: beyond 1e+100"),
    ('[[lights]]\nposition = [0, 1e300, 0]\n', "lights[0].position[1]: beyond 1e+100"),
])
def test_7_scene_values_past_the_limit_name_file_and_key(tmp_path, extra, words):
    rc, _, err = run([scene_with(tmp_path, extra), *SMALL], tmp_path)
    assert rc == 1 and words in one_line(err), err


def test_7_camera_past_the_limit(tmp_path):
    p = scene_with(tmp_path, "", camera="position = [0, 0, 1e300]\nlook_at = [0, 0, 0]\n")
    rc, _, err = run([p, *SMALL], tmp_path)
    assert rc == 1 and "camera.position[2]: beyond 1e+100" in one_line(err), err


def test_a_bare_raytrace_shows_the_help(tmp_path):
    rc, out, err = run([], tmp_path)
    assert rc == 0 and "Usage: " in out and "render" in out and err == ""


def test_a_replaced_output_keeps_its_mode(tmp_path):
    out = tmp_path / "x.png"
    out.write_bytes(OLD)
    out.chmod(0o640)
    rc, _, err = run(["spheres", *SMALL, "-o", out, "-q"], tmp_path)
    assert rc == 0, err
    assert (out.stat().st_mode & 0o777) == 0o640 and out.read_bytes() != OLD
