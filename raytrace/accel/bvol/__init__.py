"""Per-object bounding volumes, the workshop's Step 3: a box per object,
then its primitives.  ``build`` makes the boxes, ``traverse`` tests them."""
# traverse (and packet) register the traversals for the layouts build defines, so
# a layout unpickled in another process (a Dask worker) brings them along.
from raytrace.accel.bvol import build, traverse  # noqa: F401
