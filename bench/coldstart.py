"""Cold start: what a new user waits for the first time each entry point
runs, with an empty Numba cache, in a fresh process.

    python bench/coldstart.py [--json FILE] [--quick]
    python bench/coldstart.py --versus OTHER_CHECKOUT [--rounds 3]

Every row is a subprocess of its own with a new, empty cache directory
(XDG_CACHE_HOME and NUMBA_CACHE_DIR), so nothing compiled by an earlier row
or an earlier run is reused.  Wall s: the whole subprocess, Python start-up
and imports included.  Compile s: the CLI's ``time.compile_s`` (the
render kernel's and the structure builder's compile), or the first call's
time for the ray-casting API.  Build s: the CLI's build alone; for the
builder rows, the first build, its compile included.

A second table adds options one at a time to ONE cache, as a user meets
them: the first ``raytrace teapot``, then ``--accel grid``, ``--shadows
soft``, ... each row's compile is what that option adds the first time.

``--versus``: the second table only, for this checkout and another,
alternated round by round (each tree on PYTHONPATH, a fresh cache each
round): a host that drifts by more than a change between two runs of
the whole bench cannot hide it so.  Each cell lists the rounds' compile
seconds.

Markdown on stdout, progress on stderr.
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

SIZE = ["--width", "64", "--height", "48"]   # compile time does not depend on it

CAST = """
import time, numpy as np
t0 = time.perf_counter()
import raytrace
v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
f = np.array([[0, 1, 2], [1, 3, 2]])
o = np.array([[0.2, 0.2, 1.0], [0.7, 0.7, 1.0], [2, 2, 1], [0.5, 0.1, -1]])
d = np.array([[0, 0, -1.0]] * 4)
t1 = time.perf_counter()
h = raytrace.cast_rays((v, f), o, d, accel={accel!r})
t2 = time.perf_counter()
occ = raytrace.occluded((v, f), o, d, 10.0, accel={accel!r})
t3 = time.perf_counter()
assert h.hit.tolist() == [True, True, False, False] and occ.tolist() == [True, True, False, False]
print(f"{{t2 - t1}} {{t3 - t2}} {{t1 - t0}}")
"""

BUILD = """
import time
t0 = time.perf_counter()
from raytrace.scene.flatten import flatten
from raytrace.scene.builtin import teapot
from raytrace.accel.registry import build_structure
geo, ranges, _ = flatten(teapot())
t1 = time.perf_counter()
out = []
for name in {names!r}:
    t = time.perf_counter()
    build_structure(name, geo, ranges)
    out.append(time.perf_counter() - t)
print(" ".join(str(x) for x in out))
"""


def _example(name):
    from raytrace.scene.assets import assets_dir
    return str(assets_dir() / name)


ROOT = Path(__file__).resolve().parent.parent


def _env(cache, tree=None):
    env = dict(os.environ, XDG_CACHE_HOME=str(cache), NUMBA_CACHE_DIR=str(Path(cache) / "numba"))
    if tree is not None:        # that checkout's raytrace, whatever is installed
        env["PYTHONPATH"] = str(tree)
    return env


def _run(cmd, cache, cwd, tree=None):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=_env(cache, tree), cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise click.ClickException(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()[-500:]}")
    return wall, p.stdout


def cli_render(args, cache, cwd, tree=None):
    """(wall, compile, build) of one `raytrace ...` render (``tree``'s)."""
    wall, out = _run([sys.executable, "-m", "raytrace", *args, *SIZE, "--json", "-o", "cold.png"],
                     cache, cwd, tree)
    t = json.loads(out)["time"]
    return wall, t["compile_s"], t["build_s"]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def measure(quick):
    from raytrace.accel.registry import STRUCTURES
    rows, chain = [], []
    with tempfile.TemporaryDirectory(prefix="raytrace-cold-") as tmp:
        tmp = Path(tmp)
        n = 0

        def fresh():
            nonlocal n
            n += 1
            return tmp / f"cache{n}"

        shadow_modes = ("hard",) if quick else ("none", "hard", "soft")
        for accel in STRUCTURES:
            for shadows in shadow_modes:
                args = ["teapot", "--accel", accel, "--shadows", shadows]
                if shadows == "soft":
                    args += ["--light-samples", "4"]
                log("coldstart: raytrace " + " ".join(args))
                wall, comp, build = cli_render(args, fresh(), tmp)
                rows.append((f"raytrace {' '.join(args)}", wall, comp, build))
        for accel in ("bvh",) if quick else tuple(STRUCTURES):
            log(f"coldstart: cast_rays + occluded ({accel})")
            wall, out = _run([sys.executable, "-c", CAST.format(accel=accel)], fresh(), tmp)
            t_cast, t_occ, _ = (float(x) for x in out.split())
            rows.append((f"raytrace.cast_rays(..., accel={accel!r})", None, t_cast, None))
            rows.append((f"then raytrace.occluded(..., accel={accel!r})", wall, t_occ, None))
        log("coldstart: builders")
        names = [a for a in STRUCTURES if a != "none"]
        wall, out = _run([sys.executable, "-c", BUILD.format(names=names)], fresh(), tmp)
        for a, t in zip(names, out.split()):
            rows.append((f"first {a} build (teapot)", None, None, float(t)))
        rows[-1] = rows[-1][:1] + (wall,) + rows[-1][2:]

        if not quick:
            cache = fresh()
            for label, args in chain_steps():
                log(f"coldstart: {label} (one cache)")
                wall, comp, build = cli_render(args, cache, tmp)
                chain.append((label, wall, comp, build))
    return rows, chain


def chain_steps():
    """(label, args) of the one-cache table: the options as a user meets them."""
    from raytrace.accel.registry import STRUCTURES
    steps = [("raytrace teapot", ["teapot"])]
    steps += [(f"then --accel {a}", ["teapot", "--accel", a]) for a in STRUCTURES if a != "bvh"]
    return steps + [
        ("then --shadows soft", ["teapot", "--shadows", "soft", "--light-samples", "4"]),
        ("then --shadows none", ["teapot", "--shadows", "none"]),
        ("then --aov depth", ["teapot", "--aov", "depth"]),
        ("then --spp 4", ["teapot", "--spp", "4"]),
        ("then assets/whitted.toml (mirrors, glass)", [_example("whitted.toml")]),
        ("then assets/textured.toml (vertex colours, a texture)", [_example("textured.toml")])]


def versus(other, rounds):
    """The one-cache table's compile seconds for ``other`` (a checkout) and
    this one, a round of each in turn."""
    from common import markdown_table
    trees = (("other", Path(other).resolve()), ("this", ROOT))
    steps = chain_steps()
    seconds = {(label, name): [] for label, _ in steps for name, _ in trees}
    with tempfile.TemporaryDirectory(prefix="raytrace-cold-") as tmp:
        tmp = Path(tmp)
        for r in range(rounds):
            for name, tree in trees:
                log(f"coldstart: round {r + 1}, {name} ({tree})")
                cache = tmp / f"{name}{r}"
                for label, args in steps:
                    seconds[label, name].append(cli_render(args, cache, tmp, tree)[1])
    body = [[label] + [", ".join(f"{x:.2f}" for x in seconds[label, name]) for name, _ in trees]
            for label, _ in steps]
    return ("### Cold start, one cache, alternated: compile s of each round\n\n"
            + markdown_table(["Entry point", f"other ({other})", "this"], body, align="lll"))


def _f(x):
    return "-" if x is None else f"{x:.2f}"


def table(rows, title):
    from common import markdown_table
    body = [[label, _f(w), _f(c), _f(b)] for label, w, c, b in rows]
    return f"### {title}\n\n" + markdown_table(["Entry point", "Wall s", "Compile s", "Build s"],
                                              body, align="lrrr")


def markdown(rows, chain):
    out = table(rows, "Cold start: each entry point in a fresh process with an empty cache")
    if chain:
        out += "\n\n" + table(chain, "Cold start, one cache: what each option adds the first "
                                     "time it is used")
    return out


@click.command()
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
@click.option("--quick", is_flag=True, help="Only the BVH with hard shadows, cast_rays and the builders.")
@click.option("--versus", "other", type=click.Path(exists=True, file_okay=False), default=None,
              help="Another checkout: the one-cache table for both, alternated.")
@click.option("--rounds", type=click.IntRange(1), default=3, show_default=True,
              help="With --versus: rounds of each tree.")
def main(json_path, quick, other, rounds):
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    t0 = time.perf_counter()
    if other:
        print(versus(other, rounds))
        print(f"\n({time.perf_counter() - t0:.0f} s, {os.cpu_count()} cores)")
        return
    rows, chain = measure(quick)
    print(markdown(rows, chain))
    print(f"\n({time.perf_counter() - t0:.0f} s, {os.cpu_count()} cores)")
    if json_path:
        Path(json_path).write_text(json.dumps({"rows": rows, "chain": chain}, indent=2))


if __name__ == "__main__":
    main()
