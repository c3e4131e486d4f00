"""Acceleration structure builds, one module per structure: its layout (a
namedtuple class, the contract with its traversal in raytrace.kernels)
and ``build(geo, obj_ranges)``.  Builders see boxes and centroids, never
the primitives themselves.  The registry is raytrace.structures."""
from .. import jitconfig  # noqa: F401  (before any @njit: the cache directory)
