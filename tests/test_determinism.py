"""The same command with the same --seed writes the same PNG, byte for
byte, and reports the same counters: run after run, in another process,
and on one thread or two (random numbers are hashes of seed, pixel,
sample and dimension, never a generator's state; counters are per row)."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from raytrace.cli.main import main
from tests.structures import EVERY_MODE, STRUCTURES

ROOT = Path(__file__).resolve().parents[1]
# --aov: the kernels with AOV buffers are the ones the other tests compile
# for soft shadows and every structure (tests/test_extreme.py); without it
# this file alone compiled three more, ~13 s of a cold suite.
ARGS = ["teapot", "--shadows", "soft", "--light-samples", "16", "--spp", "4",
        "--width", "48", "--height", "36", "--seed", "2024", "--aov", "depth", "--json"]


def run(tmp_path, *args):
    r = CliRunner().invoke(main, [*ARGS, *args])
    assert r.exit_code == 0, r.output
    stats = json.loads(r.output)
    return Path(stats["output"]).read_bytes(), stats


@pytest.mark.parametrize("pattern", ["random", "stratified", "halton"])
def test_same_seed_same_png_and_counters_on_any_number_of_threads(tmp_path, monkeypatch, pattern):
    monkeypatch.chdir(tmp_path)
    runs = [run(tmp_path, "--pattern", pattern, "--threads", str(threads), "-o", f"{k}.png")
            for k, threads in enumerate((1, 2, 1, 2))]
    png, stats = runs[0]
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    for other_png, other in runs[1:]:
        assert other_png == png
        assert other["counters"] == stats["counters"]
    assert [s["threads"] for _, s in runs] == [1, 2, 1, 2]
    assert stats["counters"]["primary_rays"] == 48 * 36 * 4
    assert 0 < stats["counters"]["occluded_rays"] < stats["counters"]["shadow_rays"]
    # The seed does matter: another one gives another picture.
    other_png, _ = run(tmp_path, "--pattern", pattern, "--seed", "2025", "-o", "seed.png")
    assert other_png != png


def test_same_png_in_a_fresh_process_and_from_every_structure(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    png, stats = run(tmp_path, "--pattern", "halton", "-o", "here.png")
    out = subprocess.run([sys.executable, "-m", "raytrace", *ARGS, "--pattern", "halton",
                          "--threads", "1", "-o", "there.png"],
                         cwd=tmp_path, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "there.png").read_bytes() == png
    assert json.loads(out.stdout)["counters"] == stats["counters"]
    # Soft shadows from brute force and the default structure; every
    # structure with hard shadows (tests/structures.py).
    keys = ("primary_rays", "shadow_rays", "shading_points", "shadow_points", "occluded_rays")
    for accel in EVERY_MODE:
        other, s = run(tmp_path, "--pattern", "halton", "--accel", accel, "-o", f"{accel}.png")
        assert other == png, accel
        assert [s["counters"][k] for k in keys] == [stats["counters"][k] for k in keys], accel
    hard_png, hard = run(tmp_path, "--shadows", "hard", "-o", "hard.png")
    assert hard_png != png
    for accel in STRUCTURES:
        other, s = run(tmp_path, "--shadows", "hard", "--accel", accel, "-o", f"hard_{accel}.png")
        assert other == hard_png, accel
        assert [s["counters"][k] for k in keys] == [hard["counters"][k] for k in keys], accel
