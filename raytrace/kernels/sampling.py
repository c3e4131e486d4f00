"""Deterministic random numbers and light sampling patterns.

Random numbers are a hash of (seed, pixel, sample, dimension), never a
stateful generator: every pixel gets the same numbers whichever thread
renders it, so ``--threads 1`` and ``--threads 2`` write identical images.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT

PATTERN_GRID = 0        # the workshop's regular grid: cell centres, no noise, banding
PATTERN_RANDOM = 1      # uniform random: error ~ N^-1/2
PATTERN_STRATIFIED = 2  # jittered grid (Cook 1986): one random point per cell
PATTERN_HALTON = 3      # Halton (2, 3), rotated per pixel (Cranley-Patterson 1976)
PATTERN_NAMES = {"grid": PATTERN_GRID, "random": PATTERN_RANDOM,
                 "stratified": PATTERN_STRATIFIED, "halton": PATTERN_HALTON}
SQUARE_PATTERNS = ("grid", "stratified")  # need a square sample count

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


@njit(**JIT)
def mix64(z):
    """SplitMix64's finaliser (Steele et al. 2014): a strong 64-bit mix."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit(**JIT)
def hash_key(seed, a, b, c):
    z = mix64(np.uint64(seed) + _GOLDEN)
    z = mix64(z ^ np.uint64(a))
    z = mix64(z ^ np.uint64(b))
    return mix64(z ^ np.uint64(c))


@njit(**JIT)
def rand01(key, i, dim):
    """Uniform in [0, 1) from a key, a sample index and a dimension."""
    return rand01_hashed(key, mix64(np.uint64(i) * np.uint64(2) + np.uint64(dim) + _GOLDEN))


@njit(**JIT)
def rand01_hashed(key, h):
    """rand01 given its second hash h, of the sample index and dimension
    alone (sample_hashes)."""
    z = mix64(key ^ h)
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def mix64_array(z):
    """mix64 of a uint64 array, in NumPy (its products wrap as mix64's do)."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def sample_hashes(n):
    """rand01's hash of samples 0 .. n-1, dimensions 0 and 1 (entry 2 s +
    dim): the same for every pixel, so a render makes them once (its
    Lights record) and a soft shadow's sample hashes one number, not two
    (a sixth of the soft-shadow shading stage)."""
    return mix64_array(np.arange(2 * n, dtype=np.uint64) + _GOLDEN)


@njit(**JIT)
def radical_inverse(base, i):
    inv = 1.0 / base
    f = inv
    r = 0.0
    while i > 0:
        r += f * (i % base)
        i //= base
        f *= inv
    return r


@njit(**JIT)
def square_sample(pattern, s, cell, side, key, hashes):
    """Sample s on the unit square; side = sqrt(n) for square patterns (of
    n samples), whose cell (s % side, s // side) is ``cell``: the caller
    counts it along, since an integer division a sample was a fifth of a
    soft-shadow render's shading.  hashes: sample_hashes of n or more."""
    if pattern == PATTERN_GRID:
        return (cell[0] + 0.5) / side, (cell[1] + 0.5) / side
    if pattern == PATTERN_RANDOM:
        return rand01_hashed(key, hashes[2 * s]), rand01_hashed(key, hashes[2 * s + 1])
    if pattern == PATTERN_STRATIFIED:
        return ((cell[0] + rand01_hashed(key, hashes[2 * s])) / side,
                (cell[1] + rand01_hashed(key, hashes[2 * s + 1])) / side)
    # Halton with a per-pixel toroidal shift, so pixels do not share one
    # point set (which would show as structured artefacts instead of noise).
    # int64s, not literal ints: a call given a literal is compiled again
    # for each one (rand01 four times in a first render).
    zero, two, three = np.int64(0), np.int64(2), np.int64(3)
    u = radical_inverse(two, s + 1) + rand01(key, zero, two)
    v = radical_inverse(three, s + 1) + rand01(key, zero, three)
    return u - np.floor(u), v - np.floor(v)
