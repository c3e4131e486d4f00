"""A decimal m * 10**q (0 < m < 2**63) to the nearest double, or a refusal,
with the Eisel-Lemire algorithm: m, normalised, times a 128-bit
approximation of 5**q gives the double's 53 bits and the rounding, except
in the rare cases the approximation cannot decide (a near-halfway product,
a subnormal or infinite result), which the caller reads another way.

Lemire, "Number parsing at a gigabyte per second", Software: Practice and
Experience 51(8), 2021.  The table follows the paper: 5**q truncated to
128 bits for q >= 0, and 2**b / 5**-q plus one for q < 0.
"""
import numpy as np
from numba import njit

from raytrace.kernels.lowlevel import double_from_bits, leading_zeros, wide_product

Q_MIN, Q_MAX = -342, 308      # beyond these every m rounds to zero or infinity


def _powers_of_five():
    """(Q_MAX - Q_MIN + 1, 2) uint64: the low and high halves of the
    128-bit significand of 5**q, from Python's exact integers."""
    rows = []
    for q in range(Q_MIN, Q_MAX + 1):
        if q >= 0:
            p = 5 ** q
        else:
            five = 5 ** -q
            b = five.bit_length() + 127 if q >= -27 else 2 * five.bit_length() + 128
            p = (1 << b) // five + 1
        shift = p.bit_length() - 128
        p = p >> shift if shift > 0 else p << -shift
        rows.append((p & (1 << 64) - 1, p >> 64))
    return np.array(rows, np.uint64)


POWERS_OF_FIVE = _powers_of_five()
_LOW9 = np.uint64(0x1FF)
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)
_FRACTION = np.uint64((1 << 52) - 1)
_ONE, _THREE = np.uint64(1), np.uint64(3)


@njit(inline="always", error_model="numpy", _nrt=False, no_cpython_wrapper=True,
      no_cfunc_wrapper=True)
def decimal_to_double(m, q, powers):
    """The double nearest m * 10**q for 0 < m < 2**63 and Q_MIN <= q <=
    Q_MAX, or -1.0 where the product cannot decide it (then the caller
    parses the text another way).  Inlined into its caller's typing: no
    compiled function of its own."""
    w = np.uint64(m)
    clz = leading_zeros(w)
    w = w << np.uint64(clz)
    # 217706 / 2**16 is log2(10) closely enough that this is floor(q log2 10).
    exponent = ((217706 * q) >> 16) + 64 + 1023 - clz
    low5, high5 = powers[q - Q_MIN, 0], powers[q - Q_MIN, 1]
    high, low = wide_product(w, high5)
    if high & _LOW9 == _LOW9 and low + w < low:
        # The lower bits may carry into the 54 kept: add the next 64 bits
        # of 5**q's product.
        high2, low2 = wide_product(w, low5)
        merged = low + high2
        if merged < low:
            high += _ONE
        if high & _LOW9 == _LOW9 and merged == _ALL and low2 + w < low2:
            return -1.0
        low = merged
    top = high >> np.uint64(63)
    mantissa = high >> (top + np.uint64(9))
    exponent -= 1 - int(top)
    if low == 0 and high & _LOW9 == 0 and mantissa & _THREE == _ONE:
        return -1.0          # maybe a tie: left to a reader that rounds ties to even
    mantissa = (mantissa + (mantissa & _ONE)) >> _ONE
    if mantissa >> np.uint64(53):
        mantissa >>= _ONE
        exponent += 1
    if exponent <= 0 or exponent >= 0x7FF:
        return -1.0          # subnormal or infinite
    bits = (np.uint64(exponent) << np.uint64(52)) | (mantissa & _FRACTION)
    return double_from_bits(bits)
