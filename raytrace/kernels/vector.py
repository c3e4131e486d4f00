"""Small vector helpers shared by kernels of different floors (the crease
smoothing of scene/creases.py, the Open3D fields of hit_fields.py)."""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT


@njit(**JIT)
def unit3(x, y, z):
    """(x, y, z) / its length, as flatten.unit_rows computes a row (the same
    bits): where the squares over- or underflow, first divided by the
    largest component; a zero vector stays zero."""
    sq = x * x + y * y + z * z
    if 1e-290 < sq < 1e290:
        s = np.sqrt(sq)
        return x / s, y / s, z / s
    big = max(abs(x), abs(y), abs(z))
    if not big > 0.0:
        return 0.0, 0.0, 0.0
    x, y, z = x / big, y / big, z / big
    s = np.sqrt(x * x + y * y + z * z)
    return x / s, y / s, z / s
