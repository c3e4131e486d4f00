"""Reading mesh files of the layouts users have (issue 43): the big teapot
written as each layout by make_layouts.py (into bench-out/meshes, kept out
of the repository), loaded by raytrace, trimesh and Open3D (if importable)
in interleaved rounds, and each file rendered by a fresh `raytrace FILE
--width 320 --height 240` for the whole command's time and peak memory.

    python bench/bench.py --sections meshfiles [--quick]

Two comparisons, like for like.  The readers alone, file to vertex and
face arrays (and whatever normals, colours and texture coordinates the
file holds): raytrace's `read_mesh_parts`, `trimesh.load(FILE,
process=False)` and Open3D's `read_triangle_mesh`.  And all a render
needs of a file without normals: raytrace's `load_scene` (reading,
welding and the crease-angle smoothing) against Open3D's reading then
`compute_vertex_normals` (smooth everywhere: no crease split, area
weights; the file's own normals kept if it has them).
"""
import os
import sys
import tempfile
import time
from pathlib import Path

import common
from common import fmt_s, interleaved, log, markdown_table, median
from make_layouts import NAMES as LAYOUTS

FULL_DETAILS = (128, 256)         # 1.05M and 4.19M triangles
QUICK_DETAILS = (32,)             # 65,536 triangles
OUT = common.ROOT / "bench-out" / "meshes"
OURS = "raytrace load_scene"


def make_files(detail):
    """{layout: path}, writing the files that are not there yet."""
    import make_layouts
    paths = {name: OUT / f"teapot-{detail}-{name}" for name in LAYOUTS}
    missing = [name for name, p in paths.items() if not p.exists()]
    if missing:
        log(f"meshfiles: writing {', '.join(missing)} at detail {detail} to {OUT}")
        OUT.mkdir(parents=True, exist_ok=True)
        import subprocess
        subprocess.run([sys.executable, str(Path(make_layouts.__file__)), str(detail), str(OUT),
                        *missing], check=True, stdout=subprocess.DEVNULL)
    return paths


def loaders():
    """{name: load(path)}: the readers that are importable here."""
    import warnings

    import trimesh

    import raytrace
    from raytrace.scene.formats.mesh import read_mesh_parts
    out = {"raytrace read": lambda p: sum(len(part.faces) for part in read_mesh_parts(p)),
           "trimesh read": lambda p: len(trimesh.load(str(p), process=False).faces)}
    open3d = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import open3d
        open3d.utility.set_verbosity_level(open3d.utility.VerbosityLevel.Error)
        out["open3d read"] = lambda p: len(open3d.io.read_triangle_mesh(str(p)).triangles)
    except ImportError:
        pass
    out[OURS] = lambda p: sum(len(getattr(o, "faces", ())) for o in raytrace.load_scene(p).objects)
    if open3d is not None:
        out["open3d read+normals"] = lambda p: len(_open3d_normals(open3d, p).triangles)
    return out


def _open3d_normals(open3d, path):
    mesh = open3d.io.read_triangle_mesh(str(path))
    if not mesh.has_vertex_normals():
        mesh.compute_vertex_normals()
    return mesh


def run(quick):
    reads = loaders()
    rows = []
    for detail in QUICK_DETAILS if quick else FULL_DETAILS:
        paths = make_files(detail)
        for name, path in paths.items():
            def once(reader, path=path):
                t0 = time.perf_counter()
                triangles = reads[reader](path)
                return time.perf_counter() - t0, triangles
            reads[OURS](path)             # compiles or loads the kernels, untimed
            times, got = interleaved(tuple(reads), once, 0.0, 3, min_runs=1 if detail > 128 else 3)
            # A reader that read no triangles failed (Open3D on mixed polygons).
            times = {r: (t if got[r] else []) for r, t in times.items()}
            # Quick: one fresh process, the first layout's (at 65k triangles
            # each costs its start-up, which is the same for every layout).
            wall = stats = peak = None
            if not (quick and rows):
                with tempfile.TemporaryDirectory() as tmp:
                    wall, stats, peak = common.run_cli([path, "--width", 320, "--height", 240, "-o",
                                                        Path(tmp) / "m.png"], env=dict(os.environ),
                                                       cwd=tmp)
            if stats:
                rendered = (got[OURS], stats["triangles"])
            elif got[OURS] != rendered[0]:     # not the mesh the first file held
                raise RuntimeError(f"{path.name}: {got[OURS]:,} triangles read, the "
                                   f"first layout {rendered[0]:,}")
            row = {"layout": name, "detail": detail, "triangles": rendered[1],
                   "file_mb": path.stat().st_size / 1e6,
                   "load_s": {r: median(t) for r, t in times.items()},
                   "load_times_s": times, "whole_s": wall, "peak_mb": peak,
                   "time": stats["time"] if stats else None}
            log(f"  {path.name}: " + ", ".join(f"{r} {fmt_s(s)} s" for r, s in row["load_s"].items())
                + (f"; whole command {fmt_s(wall)} s, peak {peak or 0:,.0f} MB" if stats else ""))
            rows.append(row)
    return {"readers": list(reads), "rows": rows, "whole": "first" if quick else "all"}


def markdown(res):
    readers = res["readers"]
    header = (["File", "Triangles", "MB"] + [f"{r} s" for r in readers]
              + ["Whole command s", "Peak MB", "Peak B/triangle"])
    body = []
    for row in res["rows"]:
        peak = row["peak_mb"]
        none = "n/a" if row["whole_s"] is not None else "-"
        body.append([f"teapot-{row['detail']}-{row['layout']}", f"{row['triangles']:,}",
                     f"{row['file_mb']:,.0f}"]
                    + [fmt_s(row["load_s"][r]) if row["load_times_s"][r] else "failed" for r in readers]
                    + [fmt_s(row["whole_s"]) if row["whole_s"] is not None else "-",
                       f"{peak:,.0f}" if peak else none,
                       f"{peak * 2**20 / row['triangles']:,.0f}" if peak else none])
    out = ["### Mesh files: reading and the whole command, 320x240", "",
           markdown_table(header, body, align="lrr" + "r" * (len(readers) + 3)), "",
           "Load s: medians of interleaved rounds in this process (1 round at 4.2M triangles, "
           "3 below). Readers alone, file to arrays: raytrace read (`read_mesh_parts`), "
           "trimesh read (`trimesh.load(process=False)`), open3d read (`read_triangle_mesh`). "
           "With shading normals where the file has none: raytrace load_scene (read, weld, "
           "crease-angle normals), open3d read+normals (`compute_vertex_normals` after reading: "
           "smooth everywhere, no crease split). Whole command: a fresh `raytrace FILE "
           "--width 320 --height 240`, its wall time and peak resident memory"
           + (" (--quick: the first file only)" if res.get("whole") == "first" else "")
           + ". Layouts (bench/make_layouts.py): ply-plain float x y z, triangles, no normals; "
           "ply-rich big-endian doubles, normals, colours, texture coordinates, int counts, "
           "quads; obj v/vt/vn with f a/b/c; obj-plain v with f a (no normals); stl binary; "
           "stl-ascii %e coordinates."]
    return "\n".join(out)
