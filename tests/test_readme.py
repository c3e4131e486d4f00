"""The README's Python example runs and prints what it says."""
import contextlib
import io
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_python_example_runs(tmp_path, monkeypatch):
    blocks = python_blocks()
    assert blocks
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        ns = {}
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(code, str(README), "exec"), ns)
        printed = out.getvalue().splitlines()
        # Each print's output is written in the comment after it.
        expected = [c.split("  (")[0].strip() for c in re.findall(r"print\(.*\)\s*#\s*(.*)", code)]
        expected += [ln[1:].strip() for ln in code.splitlines() if ln.startswith("# [")]
        got = [re.sub(r"\s+", " ", p).strip() for p in printed]
        for want in expected:
            assert re.sub(r"\s+", " ", want) in got, (want, got)
    hits = ns["hits"]
    assert np.allclose(hits.u[:2], [0.25, 0.5]) and np.allclose(hits.v[:2], [0.5, 0.25])


def test_readme_statistics_list_is_the_counter_declaration():
    """Every counter's row in the README is derived from its declaration
    (raytrace/kernels/counters.py): label, JSON key, meaning."""
    from raytrace.kernels.counters import DECLARED
    text = README.read_text()
    rows = re.findall(r"^\| (.+?) \| `counters\.(\w+)` \| (.+?) \|$", text, flags=re.M)
    assert [(key, label, meaning) for label, key, meaning in rows] == list(DECLARED.values())


def test_readme_options_table_is_the_option_definitions():
    """Every render option's row is derived from raytrace/options.py, and
    every structure's from the registry."""
    from raytrace.accel.registry import STRUCTURES
    from raytrace.options import CREASE, OPTIONS, readme_row
    lines = README.read_text().splitlines()
    for opt in (*OPTIONS, CREASE):
        assert readme_row(opt) in lines, readme_row(opt)
    for name, s in STRUCTURES.items():
        assert f"| `{name}` | {s.summary} |" in lines, name


def test_readme_is_short():
    """The README is for users; design notes and full benchmark output live
    in docs/.  (3,000 since it gained `raytrace compare`, the teaching
    scenes' table, mesh files' materials and mirrors and glass, which
    issues 12 and 14 ask for there; the README was once 7,000.  3,400 since
    frames, tiles and Dask, with the cluster estimate issue 13 asks the
    README for.  3,450 since the example of RayScene's every-hit and
    distance queries, which issue 11 asks the README for.  3,600 for issue
    46's lines: the first-run notice, warmup, linear outputs, notebooks, example
    names; a trim to 2,500 is under way alongside.)"""
    assert len(README.read_text().split()) < 3600
