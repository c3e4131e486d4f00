"""The statistics counters, each declared once, here: its index, its JSON
key, its label in the table and what it counts (pbrt-v4's STAT_COUNTER).
The table, ``--json`` and the README's statistics list are derived from
this declaration (raytrace/renderer/stats.py; tests/test_readme.py checks the
README).

Kernels count into a small int64 array private to an image row or a
thread's block of rays (never a counter two threads share, which would
race) and the Python layer sums the rows.  Module-level ints are
compile-time constants to Numba.
"""
PRIMARY_RAYS = 0
SHADOW_RAYS = 1
PRIM_TESTS = 2
PRIM_HITS = 3
BOX_TESTS = 4
NODES_VISITED = 5
CELLS_VISITED = 6
SHADING_POINTS = 7
SHADOW_POINTS = 8
OCCLUDED_RAYS = 9
REFLECTION_RAYS = 10
REFRACTION_RAYS = 11
DEPTH_LIMITED = 12
BOUNCE_RAYS = 13
ROULETTE_ENDED = 14
EMITTER_SAMPLES = 15

# index -> (JSON key, label, meaning), in the table's order.
DECLARED = {
    PRIMARY_RAYS: ("primary_rays", "Primary rays", "camera rays: width x height x spp"),
    SHADOW_RAYS: ("shadow_rays", "Shadow rays",
                  "any-hit rays from a shading point towards a light sample"),
    PRIM_TESTS: ("prim_tests", "Ray-primitive tests",
                 "calls of the triangle, sphere or plane intersection test"),
    PRIM_HITS: ("prim_hits", "Ray-primitive hits",
                "those tests that found an intersection inside the ray's interval"),
    BOX_TESTS: ("box_tests", "Ray-box tests",
                "slab tests against object boxes, BVH nodes or the grid's bounds"),
    NODES_VISITED: ("nodes_visited", "BVH nodes visited", "BVH nodes taken off the traversal stack"),
    CELLS_VISITED: ("cells_visited", "Grid cells visited", "grid cells the 3D-DDA stepped through"),
    SHADING_POINTS: ("shading_points", "Shading points", "camera rays that hit a surface"),
    SHADOW_POINTS: ("shadow_points", "Shadow points",
                    "(shading point, light) pairs that cast shadow rays: a point facing away "
                    "from a light casts none"),
    OCCLUDED_RAYS: ("occluded_rays", "Occluded shadow rays", "shadow rays that found an occluder"),
    REFLECTION_RAYS: ("reflection_rays", "Reflection rays",
                      "rays reflected by mirror and glass surfaces (only in scenes that have them)"),
    REFRACTION_RAYS: ("refraction_rays", "Refraction rays",
                      "rays refracted into or out of glass"),
    DEPTH_LIMITED: ("depth_limited_rays", "Rays cut by --max-depth",
                    "reflection and refraction rays not cast because their path reached "
                    "--max-depth bounces: what they would have added is missing (glass shows "
                    "black there)"),
    BOUNCE_RAYS: ("bounce_rays", "Path bounce rays",
                  "--integrator path: rays continuing a path after a surface (diffuse, mirror "
                  "or glass)"),
    ROULETTE_ENDED: ("roulette_ended", "Paths ended by roulette",
                     "--integrator path: paths stopped by Russian roulette"),
    EMITTER_SAMPLES: ("emitter_samples", "Emitter samples",
                      "--integrator path: points picked on emissive triangles for next-event "
                      "estimation (one facing away casts no shadow ray)"),
}
N_COUNTERS = len(DECLARED)
# Counter rows of ray queries have one more column: the rays found bad as
# they were read (kernels/cast.py), so the Python layer can name the problem.
BAD_RAYS = N_COUNTERS
assert sorted(DECLARED) == list(range(N_COUNTERS)), "counter indices must be 0 .. N_COUNTERS - 1"
