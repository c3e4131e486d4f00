"""The 4-wide bounding volume hierarchy: its layout and builders
(``build``: binned SAH and the collapse to 4 children; ``median``,
``lbvh``, ``topdown``: other builders), its traversals (``traverse``; packets
of rays in ``packet``; counting a batch in ``count_stream``; closest points
in ``points``) and the SIMD tests they share (``simd``, ``box8``, ``f32``)."""
# traverse, packet and count_stream register the traversals for the layouts build defines, so
# a layout unpickled in another process (a Dask worker) brings them along.
from raytrace.accel.bvh import build, count_stream, packet, traverse  # noqa: F401
