"""Brute force, the workshop's Step 1: no structure, every primitive for
every ray.  ``build`` makes its (empty) layout, ``traverse`` scans."""
# traverse (and packet) register the traversals for the layouts build defines, so
# a layout unpickled in another process (a Dask worker) brings them along.
from raytrace.accel.brute import build, traverse  # noqa: F401
