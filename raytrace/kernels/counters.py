"""Indices of the per-row statistics counters.

Kernels count into a small int64 array private to the row (never a shared
counter inside prange, which would race) and the driver sums the rows.
Module-level ints are compile-time constants to Numba.
"""
PRIMARY_RAYS = 0
SHADOW_RAYS = 1
PRIM_TESTS = 2     # ray-primitive intersection tests (triangles, spheres, planes)
PRIM_HITS = 3      # tests that returned a hit inside the ray's interval
BOX_TESTS = 4      # ray-box (slab) tests: object boxes, BVH nodes, grid bounds
NODES_VISITED = 5  # BVH nodes popped and processed
CELLS_VISITED = 6  # grid cells stepped through
SHADING_POINTS = 7  # camera-ray hits that were shaded
SHADOW_POINTS = 8   # shading points that cast shadow rays
OCCLUDED_RAYS = 9   # shadow rays that found an occluder
N_COUNTERS = 10
