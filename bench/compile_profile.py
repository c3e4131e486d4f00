"""Where a cold compile goes: Numba's compile events of one command, each
function's seconds including the functions it compiled on the way (its
callees), deepest call level beside it.

    python bench/compile_profile.py [RAYTRACE ARGS ...]    (default: teapot)

Run it with an empty cache (NUMBA_CACHE_DIR and XDG_CACHE_HOME pointing at
a new folder) to see the first run's compile, or with a cache holding
another structure's kernels to see what one more structure adds.  A
function's own share is its seconds less its callees' (the next level's).
Markdown on stdout.
"""
import sys
import time

from numba.core import event


def main(args):
    recorder = event.RecordingListener()
    event.register("numba:compile", recorder)
    from click.testing import CliRunner

    from raytrace.cli.main import main as cli
    t0 = time.perf_counter()
    result = CliRunner().invoke(cli, args)
    wall = time.perf_counter() - t0
    if result.exit_code != 0:
        sys.exit(f"raytrace {' '.join(args)} failed: {result.output[-500:]}")
    starts, rows, depth = {}, [], 0
    for ts, e in recorder.buffer:
        key = (id(e.data["dispatcher"]), str(e.data["args"]))
        if e.is_start:
            depth += 1
            starts[key] = (ts, depth)
        else:
            start, level = starts.pop(key)
            depth -= 1
            rows.append((ts - start, level, e.data["dispatcher"].py_func.__qualname__))
    print(f"### Compile of `raytrace {' '.join(args)}`: {wall:.1f} s in all\n")
    print("| seconds (with callees) | level | function |\n| ---: | ---: | --- |")
    for seconds, level, name in sorted(rows, reverse=True)[:30]:
        print(f"| {seconds:.2f} | {level} | `{name}` |")


if __name__ == "__main__":
    main(sys.argv[1:] or ["teapot", "-o", "teapot.png"])
