"""Limits the kernels are built for, read by the layers above them
(file readers, options).  No imports: reading a limit loads no Numba."""

# Largest coordinate accepted.  The watertight triangle test multiplies
# three coordinate differences (each up to twice the largest coordinate)
# and the sphere test squares lengths; 1e100 keeps (2e100)^3 far below
# float64's 1.8e308.  Beyond it products overflow to inf and NaN: a file
# of 1e300s framed a camera at infinity and failed without naming the file.
MAX_COORD = 1e100

# A ray query's t_min that counts hits at the origin itself (t = 0): the
# largest float below zero, so t > FROM_ORIGIN holds for t = 0 (and -0.0)
# and for nothing behind the origin.  A negative t_min given to RayScene
# becomes this (trimesh, Embree and Open3D count a face the ray starts on).
FROM_ORIGIN = -5e-324

# Most mirror and glass bounces a ray is followed for (--max-depth): the
# render kernel keeps a stack of pending rays this deep.
MAX_BOUNCES = 16

# Rows (or corners) of a mesh's arrays at most for which a mesh reader's
# kernel not yet compiled runs as Python (kernels/uncompiled.py): ~16 us a
# corner for the crease split (0.13 s at this bound), ~25 us a row to weld
# (0.2 s), an OBJ's 32 bytes a row read at 1.5-2 MB/s (0.15 s), against 5 s
# to compile them all (docs/benchmarks.md, "Small meshes uncompiled").
UNCOMPILED_MAX = 8192
# Bytes a vertex or face line of a text file takes, about, to weigh a file
# against that bound.
BYTES_PER_ROW = 32
