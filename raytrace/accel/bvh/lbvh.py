"""LBVH (Lauterbach et al. 2009; Karras 2012, "Maximizing Parallelism in the
Construction of BVHs, Octrees, and k-d Trees"): sort primitives by the
Morton code of their centroids, then split each node where the highest
differing bit of its codes changes.  The build GPUs use; here sequential and
top-down, which gives Karras' radix tree."""
import numpy as np
from numba import njit

from raytrace.accel.bvh.topdown import RULE_MORTON, build_topdown
from raytrace.kernels.jit import BUILD, BUILD_STEP

BITS = 21   # per axis: a 63-bit code


@njit(**BUILD_STEP)
def _spread(x):
    """The 21 low bits of x, two zero bits after each (bit b to bit 3b)."""
    x &= 0x1FFFFF
    x = (x | (x << 32)) & 0x1F00000000FFFF
    x = (x | (x << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    x = (x | (x << 2)) & 0x1249249249249249
    return x


@njit(**BUILD)
def morton_codes(lo, hi):
    """63-bit Morton codes of the box centroids, quantised to 2^21 steps of
    the centroids' bounds (x in the highest bit of each triple)."""
    n = lo.shape[0]
    c0 = np.full(3, np.inf)
    c1 = np.full(3, -np.inf)
    for i in range(n):
        for a in range(3):
            c = 0.5 * (lo[i, a] + hi[i, a])
            c0[a] = min(c0[a], c)
            c1[a] = max(c1[a], c)
    scale = np.zeros(3)
    for a in range(3):
        if c1[a] > c0[a]:
            scale[a] = (2 ** BITS - 1) / (c1[a] - c0[a])
    codes = np.empty(n, np.int64)
    for i in range(n):
        code = 0
        for a in range(3):
            q = int((0.5 * (lo[i, a] + hi[i, a]) - c0[a]) * scale[a])
            code |= _spread(q) << (2 - a)
        codes[i] = code
    return codes


def build_binary(lo, hi, leaf_size):
    codes = morton_codes(lo, hi)
    order = np.argsort(codes, kind="stable").astype(np.int64)
    return build_topdown(lo, hi, order, codes[order], RULE_MORTON, leaf_size)
