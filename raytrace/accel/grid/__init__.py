"""The uniform grid: ``build`` sorts primitive boxes into cells (CSR
lists), ``traverse`` walks them by 3D-DDA."""
# traverse (and packet) register the traversals for the layouts build defines, so
# a layout unpickled in another process (a Dask worker) brings them along.
from raytrace.accel.grid import build, traverse  # noqa: F401
