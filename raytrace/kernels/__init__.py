"""Numba kernels: ray records, intersection tests, one traversal module per
structure, shading and the parallel render and ray-casting kernels.  Only
contiguous arrays of fixed dtypes, namedtuples of them and plain scalars
cross into this package; validation and dtype casting happen in the glue.
"""
# Nothing here imports raytrace from outside this package.
