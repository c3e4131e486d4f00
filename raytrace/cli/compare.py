"""`raytrace compare`: one scene rendered with several structures, timed
side by side, the workshop's table for each, and a check that every one
gave the same picture.

A structure is named as for --accel; ``bvh:median`` and ``bvh:lbvh`` name
the BVH with another builder, so builders compare like structures.
Render times are the best of ``repeat`` renders taken in turn (structure
after structure, so a noisy neighbour slows them alike); counters are
deterministic and come from the first.
"""
from dataclasses import dataclass, replace

import numpy as np

from raytrace.errors import OptionError
from raytrace.options import BY_NAME

BASELINE = "none"      # speedups are over brute force when it is compared


@dataclass
class Entry:
    label: str             # as the user wrote it: "grid", "bvh:lbvh"
    accel: str
    bvh_build: str = None  # None: the render's --bvh-build
    stats: dict = None     # the render's statistics (first render)
    cost: np.ndarray = None
    render_s: float = float("inf")


@dataclass
class Comparison:
    scene: str
    entries: list
    image: np.ndarray      # (h, w, 3) uint8: the picture every structure made
    identical: bool
    differences: list      # (label, differing pixels) of entries unlike the first

    @property
    def baseline(self):
        """The entry speedups are relative to: brute force, or the first."""
        return next((e for e in self.entries if e.label == BASELINE), self.entries[0])


def parse_entries(text):
    """Entries from "none,bvh,bvh:lbvh"; OptionError naming a bad one."""
    accel, builder = BY_NAME["accel"], BY_NAME["bvh_build"]
    entries, seen = [], set()
    for label in (part.strip() for part in str(text).split(",")):
        name, _, build = label.partition(":")
        accel.check(name)
        if build:
            if name != "bvh":
                raise OptionError(f"{label!r}: only the BVH has builders (bvh:sah, bvh:median, "
                                  f"bvh:lbvh)")
            builder.check(build)
        if label in seen:
            raise OptionError(f"{label!r} is listed twice")
        seen.add(label)
        entries.append(Entry(label, name, build or None))
    return entries


def default_entries():
    """Every structure, brute force first."""
    return [Entry(name, name) for name in BY_NAME["accel"].choice_list()]


def compare(scene, entries, opts, repeat=1, progress=None):
    """Render ``scene`` with each entry's structure (RenderOptions ``opts``
    for the rest); returns a Comparison.  progress(label) is called before
    each structure's first render."""
    from raytrace.renderer.firstrun import expecting, scene_estimate
    names = [e.accel for e in entries]
    with expecting(f"{scene.name}: {', '.join(dict.fromkeys(names))}",
                   lambda: sum(scene_estimate(scene, a) for a in dict.fromkeys(names))):
        return _compare(scene, entries, opts, repeat, progress)


def _compare(scene, entries, opts, repeat, progress):
    from raytrace.renderer.driver import render
    first = None
    differences = []
    for round_ in range(repeat):
        for e in entries:
            if round_ == 0 and progress is not None:
                progress(e.label)
            o = replace(opts, accel=e.accel, aov=True, progress=None,
                        bvh_build=e.bvh_build or opts.bvh_build)
            result = render(scene, o)
            e.render_s = min(e.render_s, result.stats["time"]["render_s"])
            if round_:
                continue
            e.stats, e.cost = result.stats, result.aovs["cost"]
            if first is None:
                first = result
                continue
            # The same picture bit for bit: the linear radiance, and which
            # primitive each pixel saw at which depth.
            same = ((result.linear == first.linear).all(axis=2)
                    & (result.aovs["primid"] == first.aovs["primid"])
                    & (result.aovs["depth"] == first.aovs["depth"]))
            if not same.all():
                differences.append((e.label, int((~same).sum())))
    for e in entries:
        e.stats["time"]["render_s"] = e.render_s
    return Comparison(scene=scene.name, entries=entries, image=first.image,
                      identical=not differences, differences=differences)


def rows(comparison):
    """The table's rows, one dict per entry (also the --json form)."""
    base = comparison.baseline.render_s
    out = []
    for e in comparison.entries:
        s, d = e.stats, e.stats["derived"]
        visits = d["nodes_per_ray"] or d["cells_per_ray"]
        out.append({
            "structure": e.label,
            "build_s": s["time"]["build_s"],
            "render_s": e.render_s,
            "speedup": base / e.render_s if e.render_s > 0 else float("inf"),
            "rays": d["rays"],
            "prim_tests_per_ray": d["prim_tests_per_ray"],
            "box_tests_per_ray": d["box_tests_per_ray"],
            "visits_per_ray": visits,
            "memory_bytes": s["structure"].get("memory_bytes", 0),
        })
    return out


COLUMNS = [  # (key, heading, format)
    ("structure", "Structure", "{}"),
    ("build_s", "Build (ms)", "{:,.2f}"),
    ("render_s", "Render (s)", "{:,.3f}"),
    ("speedup", "Speedup", None),
    ("rays", "Rays", "{:,}"),
    ("prim_tests_per_ray", "Prim tests/ray", "{:,.2f}"),
    ("box_tests_per_ray", "Box tests/ray", "{:,.2f}"),
    ("visits_per_ray", "Nodes|cells/ray", "{:,.2f}"),
    ("memory_bytes", "Memory (KiB)", "{:,.1f}"),
]


def speedup_text(x):
    """The ratio and "x": two significant figures below 10, whole numbers above."""
    return f"{x:,.0f}x" if x >= 10 else f"{x:.1f}x" if x >= 1 else f"{x:.2g}x"


def _cell(key, fmt, value):
    if key == "speedup":
        return speedup_text(value)
    if key == "build_s":
        value *= 1e3
    elif key == "memory_bytes":
        value /= 1024
    return fmt.format(value)


def format_table(comparison):
    """The workshop's table, a column per figure, and the identity line."""
    table = [[heading for _, heading, _ in COLUMNS]]
    table += [[_cell(k, f, r[k]) for k, _, f in COLUMNS] for r in rows(comparison)]
    widths = [max(len(row[i]) for row in table) for i in range(len(COLUMNS))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                       for i, (c, w) in enumerate(zip(row, widths))) for row in table]
    lines.insert(1, "-" * len(lines[0]))
    lines.append("")
    lines.append(identity_line(comparison))
    return "\n".join(lines)


def identity_line(comparison):
    n = len(comparison.entries)
    if comparison.identical:
        return (f"Images: identical from all {n} structures (radiance, depth and primitive ids, "
                f"bit for bit)." if n > 1 else "Images: one structure, nothing to compare.")
    first = comparison.entries[0].label
    return "Images DIFFER: " + "; ".join(f"{label} differs from {first} in {px:,} pixels"
                                         for label, px in comparison.differences)


def to_dict(comparison):
    """The comparison for --json: the table's rows, the identity check and
    each structure's full statistics."""
    return {
        "scene": comparison.scene,
        "baseline": comparison.baseline.label,
        "identical": comparison.identical,
        "differences": dict(comparison.differences),
        "table": rows(comparison),
        "structures": {e.label: e.stats for e in comparison.entries},
    }
