"""Render statistics: names, meanings, the table and the JSON form."""
import json

from raytrace.kernels import counters as C

# (key, label, meaning, index), from the one declaration in kernels/counters.py.
COUNTERS = [(key, label, meaning, idx) for idx, (key, label, meaning) in C.DECLARED.items()]


# Structure statistics shown in the table (all are in --json under
# "structure"), with their labels; each structure reports its own subset
# (raytrace/accel/<name>.py, statistics()).
STRUCTURE_ROWS = [
    ("nodes", "Structure: nodes"),
    ("leaves", "Structure: leaves"),
    ("max_depth", "Structure: max depth"),
    ("mean_leaf_depth", "Structure: mean leaf depth"),
    ("primitives_per_leaf_mean", "Structure: primitives per leaf"),
    ("primitives_per_leaf_max", "Structure: most primitives in a leaf"),
    ("sah_cost", "Structure: SAH cost"),
    ("duplication", "Structure: references per primitive"),
    ("boxes", "Structure: boxes"),
    ("resolution", "Structure: grid resolution"),
    ("empty_cells", "Structure: empty cells"),
    ("references_per_primitive", "Structure: references per primitive"),
    ("memory_bytes", "Structure: memory (bytes)"),
    ("bytes_per_primitive", "Structure: bytes per primitive"),
]


def counters_from_rows(rows):
    total = rows.sum(axis=0)
    return {key: int(total[idx]) for key, _, _, idx in COUNTERS}


def derive(stats):
    """Per-ray figures and throughput, from the counters and times."""
    c = stats["counters"]
    rays = (c["primary_rays"] + c["shadow_rays"] + c["reflection_rays"] + c["refraction_rays"]
            + c["bounce_rays"])
    render_s = stats["time"]["render_s"]
    stats["derived"] = {
        "rays": rays,
        "mrays_per_s": rays / render_s / 1e6 if render_s > 0 else 0.0,
        "prim_tests_per_ray": c["prim_tests"] / rays if rays else 0.0,
        "box_tests_per_ray": c["box_tests"] / rays if rays else 0.0,
        "nodes_per_ray": c["nodes_visited"] / rays if rays else 0.0,
        "cells_per_ray": c["cells_visited"] / rays if rays else 0.0,
    }
    return stats


def _fmt(v):
    if isinstance(v, float):
        return f"{v:,.3f}"
    if isinstance(v, int):
        return f"{v:,}"
    return str(v)


def format_table(stats):
    """Two aligned columns; small enough that a table library buys nothing."""
    t = stats["time"]
    d = stats["derived"]
    c = stats["counters"]
    rows = [
        ("Scene", f"{stats['scene']} ({stats['triangles']:,} triangles, {stats['spheres']} spheres, "
                  f"{stats['planes']} planes)"),
        ("Acceleration", stats["accel"]),
        ("Shadows", stats["shadows"] + (f" ({stats['light_samples']} samples, {stats['pattern']})"
                                        if stats["shadows"] == "soft" else "")),
        ("Image", f"{stats['width']}x{stats['height']}, {stats['spp']} spp, {stats['threads']} threads"
                  + (", textures unfiltered" if stats.get("texture_filter") == "none" else "")
                  + (", path traced" if stats.get("integrator") == "path" else "")),
        ("Degenerate triangles dropped", stats["degenerate_dropped"]),
        ("Render time (s)", t["render_s"]),
        ("Build time (s)", t["build_s"]),
        ("Compile/load time (s)", t["compile_s"]),
        ("Flatten time (s)", t["setup_s"]),
    ]
    if "load_s" in t:      # the command line's: reading the file and framing it
        rows.append(("Load time (s)", t["load_s"]))
    rows += _batch_rows(stats)
    if stats.get("peak_memory_mb"):
        rows.append(("Peak memory (MB)", max(stats["peak_memory_mb"].values())))
    rows += [("Rays cast", d["rays"])]
    rows += [(label, c[key]) for key, label, _, _ in COUNTERS]
    rows += [
        ("Primitive tests per ray", d["prim_tests_per_ray"]),
        ("Box tests per ray", d["box_tests_per_ray"]),
        ("Mrays/s", d["mrays_per_s"]),
    ]
    st = stats.get("structure", {})
    rows += [(label, "x".join(map(str, st[key])) if isinstance(st[key], list) else st[key])
             for key, label in STRUCTURE_ROWS if key in st]
    width = max(len(k) for k, _ in rows)
    vals = [_fmt(v) for _, v in rows]
    vwidth = max(len(v) for v in vals)
    lines = [f"{k:<{width}}  {v:>{vwidth}}" for (k, _), v in zip(rows, vals)]
    rule = "-" * (width + 2 + vwidth)
    return "\n".join([rule, *lines, rule])


def _batch_rows(stats):
    """Frames, tiles and workers (frames/batch.py): render and compile times per
    worker, and the wall-clock time their work does not explain."""
    if "frames" not in stats:
        return []
    t = stats["time"]
    rows = [("Frames", stats["frames"]), ("Tiles per frame", stats["tiles"])]
    if stats.get("frames_skipped"):
        rows.append(("Frames already written (skipped)", stats["frames_skipped"]))
    for k, w in enumerate(stats["workers"].values(), 1):
        if "warmup_s" in w:        # a Dask worker's kernel load, while the scene was built
            rows.append((f"Worker {k}: warm-up (s)", "unfinished" if w["warmup_s"] is None
                         else w["warmup_s"]))
        rows.append((f"Worker {k}: tiles, compile/load, render (s)",
                     f"{w['tiles']:,}, {w['compile_s']:,.3f}, {w['render_s']:,.3f}"))
    rows += [("Wall time (s)", t["wall_s"]),
             ("Overhead: scheduling, transfer, assembly (s)", t["overhead_s"])]
    return rows


def to_json(stats):
    return json.dumps(stats, indent=2, sort_keys=False)
