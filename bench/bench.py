"""The benchmark behind bench.sh: the workshop's table on this machine,
extended to every structure, plus scaling, a peer and error against time.

    python bench/bench.py [--quick] [--json FILE] [--plot FILE] [--sections LIST]

Markdown goes to stdout, progress to stderr.  Sections:

workshop     rows Teapot / + hard shadows / + soft shadows (81 samples),
             columns none, bvol, bvh, grid: render time (median, compile and
             build excluded), speedup over none, rays, tests per ray, Mrays/s,
             and each image's largest difference from brute force (must be 0).
scaling      BVH, grid and k-d tree over teapot tessellations up to 4.2M
             triangles: build and render time, Mrays/s, structure bytes per
             triangle, and each size's peak memory and whole-command time
             from a fresh `raytrace` process.
structures   every structure and BVH builder on four scenes, as `raytrace
             compare` measures them (accel/registry.py).
peer         our batch ray casting against Embree (embreex) or Open3D, if
             importable, on the same primary and shadow rays (peer.py).
workload     issue 40's public suite: the teapot alone at 1k, 118k and 1M
             triangles, camera, shuffled, random, shadow, bounce and float32
             rays, closest/any/count, against Open3D, embreex and Mitsuba's
             llvm variant where they import (workload.py).
convergence  soft-shadow error against run time for each sampling pattern
             (convergence.py).
path_convergence  the path tracer's error against run time on the Cornell
             box, per sampler and structure, with fitted slopes
             (path_convergence.py; bench-out/path_convergence.png).
turntable    a 36-frame teapot turntable in this process against --workers 2
             (a local Dask cluster): frames/s, Dask's overhead as a ratio,
             compile/load per worker (turntable.py; needs the distributed extra).
meshfiles    mesh files of several layouts (PLY, OBJ, STL) at 1M and 4.2M
             triangles: load time against trimesh and Open3D, the whole
             command's time and peak memory (meshfiles.py; the files go to
             bench-out/meshes).
coldstart    each entry point's first run in a fresh process with an empty
             Numba cache, and what each option adds (coldstart.py).  First,
             so that nothing else competes with it for the cores.
"""
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402
from common import ACCELS, STRUCTURES, fmt_g, fmt_s, interleaved, log, markdown_table, median  # noqa: E402

SECTIONS = ("coldstart", "workshop", "scaling", "structures", "peer", "workload", "convergence",
            "path_convergence", "turntable", "meshfiles")
# The scaling table's structures: those whose cost grows slower than the
# mesh, each with a visit counter of its own (nodes, cells).
HIERARCHICAL = tuple(n for n, s in STRUCTURES.items() if s.visit_metric)

# The workshop's table (C++, its machine unknown): seconds before and after
# bounding volumes, for the same three rows.
WORKSHOP_PAPER = {"none": (42, 64, 1800), "bvol": (6, 11, 407)}

# Per-mode settings.  budget_s: a cell gets floor(budget / first run) runs
# in all, at least 1 and at most max_runs (after its warm-up).  Scaling:
# teapot details (2 * detail^2 * 32 triangles: 43 -> 117,992, 128 ->
# 1,047,552, 256 -> 4,192,256); sizes above scaling_big get one timed
# render and no untimed one, since each render there flattens and builds
# for seconds.  scaling_whole: the details whose whole command is timed in
# a fresh process (None: all).  Quick: the workshop at 80x60, where brute
# force with soft shadows takes seconds, not tens of seconds, and one fresh
# process per structure (the biggest size): each costs its start-up, not
# the scene's.
FULL = dict(width=640, height=480, budget_s=20.0, max_runs=5,
            scaling_details=(4, 8, 16, 32, 43, 128, 256), scaling_runs=3, scaling_big=43,
            scaling_size=(640, 480), scaling_whole=None)
QUICK = dict(width=80, height=60, budget_s=1.5, max_runs=5,
             scaling_details=(4, 8, 16), scaling_runs=3, scaling_big=43,
             scaling_size=(160, 120), scaling_whole=(16,))

ROWS = (
    ("teapot", "Teapot", dict(shadows="none")),
    ("hard", "Teapot + hard shadows", dict(shadows="hard")),
    ("soft", "Teapot + soft shadows (81 samples)", dict(shadows="soft", light_samples=81,
                                                        pattern="stratified")),
)


def warm_up(scene, accel, opts, width, height):
    """One small untimed render: loads (or compiles) the kernel and the
    builder, and starts Numba's thread pool."""
    from raytrace.renderer.driver import render
    render(scene, accel=accel, width=max(16, width // 8), height=max(12, height // 8), **opts)


def cell_record(times, result):
    s = result.stats
    d = s["derived"]
    t = median(times)
    return {
        "render_s": t, "runs": len(times), "times_s": times,
        "build_s": s["time"]["build_s"], "compile_s": s["time"]["compile_s"],
        "rays": d["rays"], "prim_tests_per_ray": d["prim_tests_per_ray"],
        "box_tests_per_ray": d["box_tests_per_ray"], "nodes_per_ray": d["nodes_per_ray"],
        "cells_per_ray": d["cells_per_ray"], "mrays_per_s": d["rays"] / t / 1e6,
        "counters": s["counters"],
    }


def run_workshop(cfg):
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    scene = teapot(4)
    w, h = cfg["width"], cfg["height"]
    rows = []
    for key, label, opts in ROWS:
        log(f"workshop: {label}, {w}x{h}")
        for a in ACCELS:
            warm_up(scene, a, opts, w, h)

        def once(accel, opts=opts):
            r = render(scene, accel=accel, width=w, height=h, **opts)
            return common.render_time(r), r
        times, first = interleaved(ACCELS, once, cfg["budget_s"], cfg["max_runs"])
        cells = {}
        for a in ACCELS:
            rec = cell_record(times[a], first[a])
            rec["max_diff_vs_none"] = common.max_abs_diff(first[a].linear, first["none"].linear)
            cells[a] = rec
            log(f"  {a:5s} {fmt_s(rec['render_s'])} s x{rec['runs']}  "
                f"{fmt_g(rec['prim_tests_per_ray'])} tests/ray")
        for a in ACCELS:
            cells[a]["speedup"] = cells["none"]["render_s"] / cells[a]["render_s"]
        rows.append({"row": key, "label": label, "options": opts, "cells": cells})
        triangles = first["none"].stats["triangles"]
        del first
    return {"scene": "teapot", "detail": 4, "triangles": triangles, "width": w, "height": h, "seed": 0,
            "budget_s": cfg["budget_s"], "max_runs": cfg["max_runs"], "rows": rows}


def workshop_markdown(res):
    out = [f"### Workshop table: teapot ({res['width']}x{res['height']}, {res['triangles']:,} triangles "
           f"+ ground plane)", ""]
    header = ["Scene"] + list(ACCELS)
    body = []
    for row in res["rows"]:
        line = [row["label"]]
        for a in ACCELS:
            c = row["cells"][a]
            if a == "none":
                line.append(f"{fmt_s(c['render_s'])} s")
            else:
                line.append(f"{fmt_s(c['render_s'])} s ({c['speedup']:.1f}x)")
        body.append(line)
    out.append(markdown_table(header, body))
    paper = ", ".join(f"{lab}: {n} s -> {b} s ({n / b:.1f}x)" for lab, n, b in
                      zip(("Teapot", "+ hard shadows", "+ soft shadows"), WORKSHOP_PAPER["none"],
                          WORKSHOP_PAPER["bvol"]))
    out += ["", f"Render time, median; (speedup over none). The workshop measured none -> bvol: {paper}.",
            ""]
    header = ["Scene", "Accel", "Runs", "Render s", "Speedup", "Rays", "Prim tests/ray",
              "Box tests/ray", "Nodes or cells/ray", "Mrays/s", "Max diff vs none"]
    body = []
    for row in res["rows"]:
        for a in ACCELS:
            c = row["cells"][a]
            metric = STRUCTURES[a].visit_metric
            visits = c[metric] if metric else None
            body.append([row["label"], a, c["runs"], fmt_s(c["render_s"]),
                         f"{c['speedup']:.1f}x", f"{c['rays']:,}",
                         fmt_g(c["prim_tests_per_ray"]), fmt_g(c["box_tests_per_ray"]),
                         fmt_g(visits) if visits is not None else "-", fmt_g(c["mrays_per_s"]),
                         fmt_g(c["max_diff_vs_none"])])
    out.append(markdown_table(header, body, align="ll" + "r" * 9))
    out += ["", (f"Runs: timed renders per cell after one untimed warm-up render; a cell gets "
                 f"floor({res['budget_s']:g} s / its first run) runs, at least 1, at most "
                 f"{res['max_runs']}, in interleaved rounds (all cells in turn). Render time is "
                 f"the kernel's wall time: Numba compile/cache load (`time.compile_s`) and the "
                 f"structure build (`time.build_s`) are excluded. Max diff vs none: largest "
                 f"absolute difference of the linear float image from brute force's, over all "
                 f"pixels and channels (0 means identical).")]
    return "\n".join(out)


def run_scaling(cfg):
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    w, h = cfg.get("scaling_size", (cfg["width"], cfg["height"]))
    whole = cfg.get("scaling_whole") or cfg["scaling_details"]
    structures = cfg.get("scaling_structures", HIERARCHICAL)
    for a in structures:
        warm_up(teapot(2), a, {}, w, h)
    rows = []
    for detail in cfg["scaling_details"]:
        big = detail > cfg["scaling_big"]
        runs = 1 if big else cfg["scaling_runs"]
        log(f"scaling: teapot detail {detail}, {runs} run(s) each")
        scene = teapot(detail)
        if not big:
            for a in structures:   # untimed: first render of this mesh size
                render(scene, accel=a, width=16, height=12, shadows="hard")

        def once(accel, scene=scene):
            r = render(scene, accel=accel, width=w, height=h, shadows="hard")
            return common.render_time(r), r
        builds = {a: [] for a in structures}

        def once_logged(accel, once=once, builds=builds):
            t, r = once(accel)
            builds[accel].append(r.stats["time"]["build_s"])
            return t, r
        times, first = interleaved(structures, once_logged, 0.0, runs, min_runs=runs)
        row = {"detail": detail, "triangles": None, "runs": runs, "cells": {}}
        for a in structures:
            rec = cell_record(times[a], first[a])
            rec["build_s"] = median(builds[a])
            rec["build_times_s"] = builds[a]
            # The driver's statistics already measure the structure it built.
            rec["structure_bytes"] = first[a].stats["structure"]["memory_bytes"]
            row["triangles"] = first[a].stats["triangles"]
            rec["structure_bytes_per_triangle"] = rec["structure_bytes"] / row["triangles"]
            row["cells"][a] = rec
        del first, scene, once, once_logged   # the scene and structures: GBs at 4.2M triangles
        for a in structures:
            rec = row["cells"][a]
            rec["whole_s"] = rec["peak_mb"] = rec["process"] = None
            if detail not in whole:
                log(f"  {a:6s} build {fmt_s(rec['build_s'])} s, render {fmt_s(rec['render_s'])} s")
                continue
            rec["whole_s"], rec["peak_mb"], rec["process"] = whole_command(detail, a, w, h)
            log(f"  {a:6s} build {fmt_s(rec['build_s'])} s, render {fmt_s(rec['render_s'])} s; "
                f"whole command {fmt_s(rec['whole_s'])} s, peak {fmt_g(rec['peak_mb'])} MB")
            if rec["process"]["triangles"] != row["triangles"]:
                raise RuntimeError(f"raytrace teapot --detail {detail} made "
                                   f"{rec['process']['triangles']:,} triangles, not {row['triangles']:,}")
        rows.append(row)
    return {"width": w, "height": h, "shadows": "hard", "runs": cfg["scaling_runs"],
            "big_above_detail": cfg["scaling_big"], "whole_details": list(whole), "rows": rows}


def whole_command(detail, accel, w, h):
    """(wall s, peak MB, its statistics' times, triangles and phase peaks)
    of one fresh `raytrace teapot` process: a process's peak (VmHWM) only
    grows, so each size's peak needs a process of its own."""
    import raytrace
    env = dict(os.environ)   # the child imports the raytrace this process measured
    env["PYTHONPATH"] = os.pathsep.join(
        [str(Path(raytrace.__file__).resolve().parent.parent)]
        + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    with tempfile.TemporaryDirectory() as tmp:     # cwd too: not this checkout's tree by accident
        wall, stats, peak = common.run_cli(
            ["teapot", "--detail", detail, "--accel", accel, "--shadows", "hard", "--width", w,
             "--height", h, "-o", Path(tmp) / "scaling.png"], env=env, cwd=tmp)
    # peak_memory_mb: the driver's VmHWM after each phase (load, flatten,
    # build, render), which says which phase set the peak.
    return wall, peak, {"triangles": stats["triangles"], "time": stats["time"],
                        "structure_bytes": stats["structure"]["memory_bytes"],
                        "peak_memory_mb": stats.get("peak_memory_mb")}


def scaling_markdown(res):
    out = [f"### Scaling: teapot tessellations, hard shadows, {res['width']}x{res['height']}", ""]
    header = ["Detail", "Triangles", "Accel", "Build ms", "Render s", "Mrays/s", "Prim tests/ray",
              "Nodes or cells/ray", "Structure MB", "Structure B/triangle", "Peak MB", "Whole s"]
    body = []
    for row in res["rows"]:
        for a in row["cells"]:
            c = row["cells"][a]
            visits = c[STRUCTURES[a].visit_metric]
            body.append([row["detail"], f"{row['triangles']:,}", a, fmt_g(c["build_s"] * 1e3),
                         fmt_s(c["render_s"]), fmt_g(c["mrays_per_s"]), fmt_g(c["prim_tests_per_ray"]),
                         fmt_g(visits), fmt_g(c["structure_bytes"] / 2**20),
                         f"{c['structure_bytes_per_triangle']:,.0f}",
                         f"{c['peak_mb']:,.0f}" if c["peak_mb"] is not None else
                         "n/a" if c["whole_s"] is not None else "-",
                         fmt_s(c["whole_s"]) if c["whole_s"] is not None else "-"])
    out.append(markdown_table(header, body, align="rrl" + "r" * 9))
    big = [r["detail"] for r in res["rows"] if r["detail"] > res["big_above_detail"]]
    runs = (f"Build ms to Nodes or cells/ray: medians of {res['runs']} interleaved renders in this "
            f"process (after an untimed one at that size)")
    if big:
        runs += (f"; details above {res['big_above_detail']} ({', '.join(map(str, big))}) one "
                 f"render each and no untimed one, since there each render flattens and builds "
                 f"for seconds")
    fresh = "per row"
    if set(res["whole_details"]) != {r["detail"] for r in res["rows"]}:
        fresh = f"per row at detail {', '.join(map(str, res['whole_details']))} only (- elsewhere)"
    out += ["", (f"{runs}. The build time is the driver's `time.build_s` of those renders (the "
                 f"builders are compiled before timing). Structure MB: bytes of the structure's "
                 f"arrays (`structure.memory_bytes` of the render's statistics); Structure "
                 f"B/triangle: those bytes over the triangles. Peak MB and Whole s: a fresh process "
                 f"{fresh}, `raytrace teapot --detail N --accel A --shadows hard --width "
                 f"{res['width']} --height {res['height']} --json -o FILE`: its own peak resident "
                 f"memory (VmHWM: the scene, flattened arrays, structure and image, plus Python, "
                 f"NumPy and Numba), and its wall time, what a user waits: imports, making the "
                 f"teapot, flattening, the build, loading the cached kernel, the render and "
                 f"writing the PNG.")]
    return "\n".join(out)


def chosen_sections(text, quick):
    """The sections to run: ``text`` (comma-separated) or the default, every
    section, and with --quick every one but coldstart (it compiles each
    kernel from empty caches: minutes, not the quick look --quick is for)."""
    if text is None:
        return [s for s in SECTIONS if not (quick and s == "coldstart")]
    return [s.strip() for s in text.split(",") if s.strip()]


@click.command()
@click.option("--quick", is_flag=True, help="Small images and fewer sizes, and no coldstart section "
                                           "unless --sections names it: under a minute once compiled.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="Also write every number as JSON.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default="bench-out/convergence.png",
              show_default=True, help="PNG of error against time (needs matplotlib).")
@click.option("--sections", default=None,
              help="Comma-separated subset of: " + ", ".join(SECTIONS) + " [default: all; with "
                   "--quick all but coldstart, which compiles every kernel from empty caches]")
def main(quick, json_path, plot_path, sections):
    """Benchmark raytrace's acceleration structures; Markdown on stdout."""
    chosen = chosen_sections(sections, quick)
    bad = [s for s in chosen if s not in SECTIONS]
    if bad:
        raise click.UsageError(f"unknown section(s) {', '.join(bad)}; choose from {', '.join(SECTIONS)}")
    cfg = QUICK if quick else FULL
    t0 = time.perf_counter()
    info = common.machine_info()
    report = {"mode": "quick" if quick else "full", "machine": info}
    print(f"## raytrace benchmark ({report['mode']})\n")
    print(f"Machine: {common.machine_line(info)}. Python {info['python']}, Numba {info['numba']}, "
          f"NumPy {info['numpy']}; commit {info['git_commit'] or 'unknown'}; {info['date']}.\n")
    sys.stdout.flush()
    report["section_s"] = {}
    for name in SECTIONS:
        if name in chosen:
            t = time.perf_counter()
            report[name], text = _run_section(name, cfg, quick, plot_path)
            print(text + "\n", flush=True)
            report["section_s"][name] = time.perf_counter() - t
            log(f"{name}: {report['section_s'][name]:.0f} s")
    try:
        load = [round(x, 2) for x in __import__("os").getloadavg()]
    except OSError:
        load = None
    report["wall_s"] = time.perf_counter() - t0
    report["load_avg_at_end"] = load
    each = ", ".join(f"{name} {t:.0f} s" for name, t in report["section_s"].items())
    print(f"Total wall time {report['wall_s']:.0f} s ({each})"
          + (f"; load average {load[0]:.1f} at the end." if load else "."))
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(report, indent=2, default=_json_default) + "\n")
        log(f"wrote {json_path}")


def _run_section(name, cfg, quick, plot_path):
    """(the section's numbers, its Markdown)."""
    if name == "workshop":
        res = run_workshop(cfg)
        return res, workshop_markdown(res)
    if name == "scaling":
        res = run_scaling(cfg)
        return res, scaling_markdown(res)
    module = __import__(name)
    if name == "coldstart":
        rows, chain = module.measure(quick)
        return {"rows": rows, "chain": chain}, module.markdown(rows, chain)
    if name == "convergence":
        res = module.run(quick, plot_path)
    elif name == "path_convergence":
        res = module.run(quick, Path(plot_path).with_name("path_convergence.png"))
    elif name == "turntable":
        # Quick: a third of the frames; the cluster's start-up is the same.
        res = module.measure(frames=12 if quick else 36, repeat=1 if quick else 3)
    else:
        res = module.run(quick)
    return res, module.markdown(res)


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    raise TypeError(type(o).__name__)


if __name__ == "__main__":
    main()
