"""The path tracer's Sobol sampler (kernels/sobol.py): its second
dimension against Sobol's direction numbers, and the stratification that
Owen scrambling and the index shuffle must keep."""
import numpy as np

from raytrace.kernels import sobol
from raytrace.kernels.jit import python_callable


def direction_numbers_dim2(i):
    """Sobol's second dimension by its definition (primitive polynomial
    x + 1: v_1 = 1/2, v_k = v_(k-1) xor v_(k-1) / 2), as a 32-bit fraction."""
    y, v = 0, 1 << 31
    while i:
        if i & 1:
            y ^= v
        i >>= 1
        v ^= v >> 1
    return y


def test_second_dimension_and_elementary_intervals():
    flip = python_callable(sobol.superset_xor)
    rev = python_callable(sobol.reverse_bits32)
    rng = np.random.default_rng(3)
    for i in [0, 1, 2, 3, 4, 5, 1023, *rng.integers(0, 2 ** 32, 40).tolist()]:
        assert int(rev(flip(np.uint64(i)))) == direction_numbers_dim2(i), i
    pair = python_callable(sobol.sobol_pair01)
    for key, p in ((5, 0), (2 ** 60 + 3, 7), (123456789, 0x7FFFFFFF)):
        for m in (4, 6):
            pts = np.array([pair(np.uint64(key), s, p) for s in range(2 ** m)])
            # A (0, m, 2)-net: each box of 2^a x 2^(m-a) cells holds one point.
            for a in range(m + 1):
                cells = set(zip((pts[:, 0] * 2 ** a).astype(int),
                                (pts[:, 1] * 2 ** (m - a)).astype(int)))
                assert len(cells) == 2 ** m, (key, p, m, a)
        # Another key (pixel) or pair: other points.
        other = np.array([pair(np.uint64(key + 1), s, p) for s in range(16)])
        assert not np.allclose(pts[:16], other)
