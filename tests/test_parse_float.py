"""Eisel-Lemire's decimal-to-double (kernels/parse_float.py) against
Python's float(), which rounds correctly: every answer it gives is
float()'s, bit for bit, and it declines only where the 128-bit product
cannot decide; and the OBJ kernel reads the 17 digits of Python's repr
itself, leaving none to NumPy's parser."""
import math
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np
from numba import njit

from raytrace.kernels.lowlevel import leading_zeros, wide_product
from raytrace.kernels.parse_float import POWERS_OF_FIVE, Q_MAX, Q_MIN, decimal_to_double
from raytrace.scene.formats import objtext as T


@njit
def convert(ms, qs, powers, out):
    for i in range(len(ms)):
        out[i] = decimal_to_double(ms[i], qs[i], powers)


def halfway(x):
    """The decimal halfway between the double x and the next one up, cut
    to 18 significant digits (at or near a tie)."""
    with localcontext() as c:
        c.prec = 18
        return str((Decimal(x) + Decimal(math.nextafter(x, math.inf))) / 2)


def is_tie(m, q, near):
    """m * 10**q (whose nearest double is ``near``) exactly halfway between
    two normal doubles."""
    if not np.finfo(float).tiny <= near < np.inf:
        return False
    value = Fraction(m) * Fraction(10) ** q
    sides = (math.nextafter(near, side) for side in (-math.inf, math.inf))
    return any(value == (Fraction(near) + Fraction(other)) / 2 for other in sides if other < np.inf)


def decimals(rng, k):
    """(m, q, value, tie): reprs, %.17g, long mantissas at far exponents,
    integers up to 18 digits, and values at or near a tie."""
    texts = [repr(x) for x in (rng.uniform(-2, 2, k) * 10.0 ** rng.integers(-300, 300, k)).tolist()]
    texts += ["%.17g" % x for x in rng.random(k).tolist()]
    texts += ["%d.%de%d" % (a, b, c) for a, b, c in zip(rng.integers(1, 10, k), rng.integers(0, 10 ** 16, k),
                                                       rng.integers(-345, 310, k))]
    texts += ["%d" % n for n in rng.integers(1, 10 ** 18, k)]
    texts += [halfway(x) for x in (rng.uniform(0.5, 1, k) * 10.0 ** rng.integers(-20, 20, k)).tolist()]
    texts += ["9007199254740993", "9007199254740992", "123456789012345678", "1e-342",
              "2.2250738585072011e-308", "1.7976931348623157e308", "1.7976931348623159e308", "4.9e-324"]
    out = []
    for text in texts:
        mantissa, _, exponent = text.lower().lstrip("-").partition("e")
        whole, _, fraction = mantissa.partition(".")
        m, q = int(whole + fraction), int(exponent or 0) - len(fraction)
        if 0 < m < 10 ** 18 and Q_MIN <= q <= Q_MAX:
            out.append((m, q, abs(float(text)), is_tie(m, q, abs(float(text)))))
    return out


def test_every_answer_is_the_correctly_rounded_double():
    """Exact ties included: those it answers are rounded to even."""
    rows = decimals(np.random.default_rng(5), 20000)
    ms, qs = (np.array([r[i] for r in rows], np.int64) for i in (0, 1))
    want = np.array([r[2] for r in rows])
    tie = np.array([r[3] for r in rows])
    got = np.empty(len(rows))
    convert(ms, qs, POWERS_OF_FIVE, got)
    answered = got >= 0
    assert np.array_equal(got[answered].view(np.uint64), want[answered].view(np.uint64))
    # Always declined: subnormals and overflows.  Else declined only where
    # the product's low bits are all zero (an exact tie, or a product too
    # near one to tell), a few in ten thousand of these.
    normal = (want >= np.finfo(float).tiny) & (want < np.inf)
    assert not answered[~normal].any()
    assert (normal & ~tie & ~answered).sum() < 1e-3 * (normal & ~tie).sum()
    assert tie.sum() > 100


def test_the_kernel_reads_seventeen_digit_numbers_itself():
    """A line of reprs (trimesh's ASCII STL writes them) is read by the
    kernel, none copied out for NumPy; the values are float()'s."""
    rng = np.random.default_rng(8)
    rows = rng.normal(0, 3, (500, 3))
    text = "".join("v %r %r %r\n" % tuple(r) for r in rows.tolist()).encode()
    data = np.frombuffer(bytearray(text), np.uint8)
    state = np.zeros(T.STATE_SIZE, np.int64)
    v = np.empty((500, 3))
    index = np.empty(1, np.int32)
    code = T.parse_lines(data, len(data), state, v, v, index, index, index, np.empty(2 * len(text), np.uint8),
                         np.empty(len(text), np.int64), T.POW10, POWERS_OF_FIVE)
    assert code == 0 and state[T.NV] == 500
    assert state[T.NFB] == 0
    assert np.array_equal(v.view(np.uint64), rows.view(np.uint64))


@njit
def products(a, b, out, zeros):
    for i in range(len(a)):
        out[i, 0], out[i, 1] = wide_product(a[i], b[i])
        zeros[i] = leading_zeros(a[i])


def test_wide_product_and_leading_zeros_are_python_integers():
    rng = np.random.default_rng(1)
    shifts = rng.integers(0, 64, 1000).astype(np.uint64)
    a = rng.integers(0, 2 ** 64, 1000, np.uint64, endpoint=False) >> shifts
    b = rng.integers(0, 2 ** 64, 1000, np.uint64, endpoint=False)
    a[:2], b[:2] = [0, 2 ** 64 - 1], [2 ** 64 - 1, 2 ** 64 - 1]
    out, zeros = np.empty((1000, 2), np.uint64), np.empty(1000, np.int64)
    products(a, b, out, zeros)
    for x, y, (high, low), z in zip(a.tolist(), b.tolist(), out.tolist(), zeros.tolist()):
        assert (high << 64 | low) == x * y and z == 64 - x.bit_length()
