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


@pytest.mark.parametrize("delay_ms", [1, 2, 3, 5, 7, 10, 14, 20, 30])
def test_13_ctrl_c_while_the_console_script_imports(tmp_path, delay_ms):
    """The console script pip writes, run with -X importtime so the signal
    can be sent a given time after the first of our modules has loaded
    (the next line after site's): before that, Python's own start-up and
    import machinery run, not our code."""
    module, function = _console_entry()
    script = f"import sys\nfrom {module} import {function}\nsys.exit({function}())\n"
    p = subprocess.Popen([sys.executable, "-X", "importtime", "-c", script, "spheres",
                          "--width", "16", "--height", "12", "-o", "x.png"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    for line in p.stderr:
        if line.rstrip().endswith("| site"):
            break
    first = p.stderr.readline()
    time.sleep(delay_ms / 1000)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    err = "".join(ln for ln in err.splitlines(keepends=True) if not ln.startswith("import time:"))
    assert first.rstrip().endswith(f"| {module}")
    assert (p.returncode, lines(err)) == (130, ["interrupted: no image written"])
    assert list(tmp_path.iterdir()) == []
