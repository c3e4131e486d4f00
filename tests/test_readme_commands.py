"""The README's commands run as written, from a clone (assets/ beside
the working directory): every `raytrace ...` line of its shell blocks and
picture captions is either run here or named below as too slow for the
suite, with the reason."""
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

SLOW = {
    "raytrace teapot --shadows soft --no-bvol": "brute force, 81 shadow rays a point: a minute",
    "raytrace teapot --detail 16 --shadows soft --spp 16": "16 samples a pixel of 16k triangles",
    "raytrace compare teapot --accel bvh,bvh:median,bvh:lbvh,kdtree --detail 43":
        "three renders of 118k triangles with each of four structures",
    "raytrace teapot --turntable 36": "36 frames of 640x480",
    "raytrace assets/flyby.toml -o frames/f_%04d.png --resume": "48 frames",
    "raytrace teapot --turntable 360 --workers 2 -o spin.mp4": "360 frames on a Dask cluster",
    "raytrace teapot --width 8000 --height 6000 --scheduler tcp://host:8786":
        "needs a running Dask scheduler",
    "raytrace assets/textured.toml --shadows soft --spp 4": "soft shadows with textures: a compile "
                                                            "of its own",
    "raytrace teapot_room --spp 128 --sampler sobol": "128 path-traced samples a pixel at 640x480: "
                                                      "half a minute",
    # Seconds each, which CI's budget does not have: covered in small by
    # test_cli.py, test_cli_files.py and test_compare.py.
    "raytrace teapot --no-bvol --heatmap cost.png": "brute force over 640x480 with shadows",
    "raytrace teapot --shadows soft": "81 shadow rays a point at 640x480",
    "raytrace teapot --detail 43 --json": "tessellating and building 118k triangles",
    "raytrace compare teapot --quick": "seven renders, brute force among them",
}


def readme_commands():
    """Each `raytrace` command of the README, without its comment."""
    text = README.read_text()
    lines = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        lines += [re.split(r"\s#", ln)[0].strip() for ln in block.splitlines()
                  if ln.startswith("raytrace ")]
    # Picture captions: | `raytrace ...` |
    lines += re.findall(r"\| `(raytrace [^`]*)`", text)
    return list(dict.fromkeys(lines))


def test_every_readme_command_is_run_or_named_slow():
    commands = readme_commands()
    assert len(commands) >= 15
    assert set(SLOW) <= set(commands), set(SLOW) - set(commands)


FAST = [c for c in readme_commands() if c not in SLOW]


@pytest.mark.parametrize("command", FAST)
def test_readme_command_runs_verbatim(command, tmp_path):
    (tmp_path / "assets").symlink_to(ROOT / "assets")
    args = shlex.split(command)
    r = subprocess.run([sys.executable, "-m", "raytrace", *args[1:]], cwd=tmp_path,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, (command, r.stderr)
    assert "Traceback" not in r.stderr and "Error" not in r.stderr, r.stderr
    if args[1] not in ("scenes", "compare") and "--json" not in args:
        assert "wrote " in r.stdout, r.stdout
