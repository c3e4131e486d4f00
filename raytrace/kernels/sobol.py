"""Owen-scrambled Sobol points with hash-based scrambling (Burley 2020,
"Practical Hash-based Owen Scrambling", JCGT 9(4)), for the path
tracer's ``--sampler sobol``.

Each pair of a path's dimensions is a 2-D Sobol point (the sequence's
first two dimensions, a (0, 2)-sequence: any 2^m consecutive points
stratify the square in every elementary interval), its index shuffled
and its coordinates Owen-scrambled by hashes of the pixel's key and the
pair: pairs are decorrelated from one another ("padding") and pixels
from their neighbours, and a pixel's numbers depend on nothing but the
seed, the pixel, the sample's index and the dimension, so tiles, threads
and workers give the same bits.  Imported by the path tracer only.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT
from raytrace.kernels.sampling import mix64

_MASK = np.uint64(0xFFFFFFFF)
_ONE = np.uint64(1)


@njit(**JIT)
def reverse_bits32(x):
    """x's low 32 bits in reverse order."""
    x = ((x >> np.uint64(1)) & np.uint64(0x55555555)) | ((x & np.uint64(0x55555555)) << _ONE)
    x = ((x >> np.uint64(2)) & np.uint64(0x33333333)) | ((x & np.uint64(0x33333333))
                                                          << np.uint64(2))
    x = ((x >> np.uint64(4)) & np.uint64(0x0F0F0F0F)) | ((x & np.uint64(0x0F0F0F0F))
                                                          << np.uint64(4))
    x = ((x >> np.uint64(8)) & np.uint64(0x00FF00FF)) | ((x & np.uint64(0x00FF00FF))
                                                          << np.uint64(8))
    return ((x >> np.uint64(16)) | (x << np.uint64(16))) & _MASK


@njit(**JIT)
def laine_karras(x, seed):
    """Burley's improved Laine-Karras hash: a bijection of 32-bit words in
    which each bit depends only on itself and the bits below it (adds and
    products by even numbers carry upwards only)."""
    x = (x + seed) & _MASK
    x = (x ^ (x * np.uint64(0x6C50B47C))) & _MASK
    x = (x ^ (x * np.uint64(0xB82F1E52))) & _MASK
    x = (x ^ (x * np.uint64(0xC7AFE638))) & _MASK
    return (x ^ (x * np.uint64(0x8D22F6E6))) & _MASK


@njit(**JIT)
def superset_xor(i):
    """Bit r of the result: the xor of i's bits c whose positions contain r
    (c & r == r).  Sobol's second dimension's generator matrix is Pascal's
    triangle mod 2, whose entry (r, c) is odd exactly then (Lucas), so
    this is that dimension's point i with its bits reversed; five steps
    instead of a loop over i's 32 bits."""
    i ^= (i >> _ONE) & np.uint64(0x55555555)
    i ^= (i >> np.uint64(2)) & np.uint64(0x33333333)
    i ^= (i >> np.uint64(4)) & np.uint64(0x0F0F0F0F)
    i ^= (i >> np.uint64(8)) & np.uint64(0x00FF00FF)
    return i ^ ((i >> np.uint64(16)) & np.uint64(0x0000FFFF))


@njit(**JIT)
def sobol_pair01(pixel_key, sample, pair):
    """Pair ``pair`` of the sample's point in [0, 1)^2: the first two
    dimensions of Sobol's point number ``sample``, its index shuffled (a
    nested uniform scramble: a permutation of each aligned block of 2^m
    indices, so the first 2^m samples keep their stratification) and its
    coordinates Owen-scrambled, each by its own hash.  Owen scrambling
    reverses bits, hashes and reverses again; the van der Corput point is
    i reversed, so reversing twice cancels: reverse(LK(i))."""
    seed = mix64(pixel_key ^ mix64(np.uint64(pair) + np.uint64(0x50B0)))
    index = reverse_bits32(laine_karras(reverse_bits32(np.uint64(sample) & _MASK), seed & _MASK))
    u = reverse_bits32(laine_karras(index, mix64(seed ^ _ONE) & _MASK))
    v = reverse_bits32(laine_karras(superset_xor(index), mix64(seed ^ np.uint64(2)) & _MASK))
    return np.float64(u) * (1.0 / 4294967296.0), np.float64(v) * (1.0 / 4294967296.0)
