"""bench.sh's ``structures`` section: every structure and BVH builder on
the teapot, the 118k-triangle teapot, the teapot in a stadium, the scene
of many sizes, Whitted's mirrors and glass and the textured example,
through ``raytrace compare`` (raytrace/cli/compare.py): build time, render
time (best of interleaved renders), speedup, tests and nodes or cells per
ray, memory, and the identical-images check.

Brute force and per-object boxes are left out where one render would take
minutes (the 118k teapot, the stadium): they add nothing there but waiting.
"""
from common import fmt_g, log, markdown_table

from raytrace.cli.compare import compare, parse_entries, rows, speedup_text
from raytrace.renderer.driver import RenderOptions
from raytrace.scene.assets import assets_dir
from raytrace.scene.load import load_scene

EVERY = "none,bvol,bvh,bvh:median,bvh:lbvh,grid,kdtree"
HIERARCHIES = "bvh,bvh:median,bvh:lbvh,grid,kdtree"


def _example(name):
    return assets_dir() / name


def cases():
    """(title, scene loader, entries) of the section, in order."""
    return [
        ("Teapot (992 triangles)", lambda w, h: load_scene("teapot", width=w, height=h), EVERY),
        ("Teapot, detail 43 (117,992 triangles)",
         lambda w, h: load_scene("teapot", detail=43, width=w, height=h), HIERARCHIES),
        ("Teapot in a stadium (assets/stadium.toml)",
         lambda w, h: load_scene(_example("stadium.toml"), width=w, height=h), HIERARCHIES),
        ("Many sizes (assets/sizes.toml)",
         lambda w, h: load_scene(_example("sizes.toml"), width=w, height=h), EVERY),
        ("Mirrors and glass (assets/whitted.toml)",
         lambda w, h: load_scene(_example("whitted.toml"), width=w, height=h), EVERY),
        ("Vertex colours and a texture (assets/textured.toml)",
         lambda w, h: load_scene(_example("textured.toml"), width=w, height=h), EVERY),
    ]


def run(quick):
    w, h = (160, 120) if quick else (640, 480)
    repeat = 1 if quick else 3
    out = []
    for title, load, entries in cases():
        log(f"structures: {title}")
        result = compare(load(w, h), parse_entries(entries), RenderOptions(), repeat=repeat)
        out.append({"title": title, "width": w, "height": h, "repeat": repeat,
                    "identical": result.identical, "baseline": result.baseline.label,
                    "rows": rows(result)})
    return out


def markdown(res):
    parts = ["### Structures and builders compared (`raytrace compare`)\n"]
    for case in res:
        parts.append(f"**{case['title']}**, {case['width']}x{case['height']}, hard shadows, "
                     f"best of {case['repeat']}; speedup over {case['baseline']}; images "
                     f"{'identical' if case['identical'] else 'DIFFER'}.\n")
        header = ["Structure", "Build (ms)", "Render (s)", "Speedup", "Prim tests/ray",
                  "Box tests/ray", "Nodes or cells/ray", "Memory (KiB)"]
        body = [[r["structure"], fmt_g(r["build_s"] * 1e3), f"{r['render_s']:.4f}",
                 speedup_text(r["speedup"]), f"{r['prim_tests_per_ray']:.2f}",
                 f"{r['box_tests_per_ray']:.2f}", f"{r['visits_per_ray']:.2f}",
                 f"{r['memory_bytes'] / 1024:,.1f}"] for r in case["rows"]]
        parts.append(markdown_table(header, body) + "\n")
    return "\n".join(parts)
