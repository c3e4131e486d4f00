"""Acceleration structure builds, one module per structure: its layout (a
namedtuple class, the contract with its traversal in raytrace.kernels)
and ``build(geo, obj_ranges)``.  Builders see boxes and centroids, and
the kd-tree also the triangles (it clips them to its cells).  The registry
is raytrace.accel.registry."""
