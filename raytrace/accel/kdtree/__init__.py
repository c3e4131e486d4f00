"""The kd-tree: ``build`` splits by binned SAH and clips triangles to the
cells, ``traverse`` walks front to back."""
# traverse (and packet) register the traversals for the layouts build defines, so
# a layout unpickled in another process (a Dask worker) brings them along.
from raytrace.accel.kdtree import build, traverse  # noqa: F401
