"""The compiled half of the OBJ reader (scene/formats/obj.py): one pass
over a chunk of whole lines, writing positions, normals and face corners
into arrays the caller allocated at their bound.

Numbers are read exactly or not at all.  A coordinate of at most 18
significant digits, m * 10**e, is correctly rounded by one IEEE multiply
or divide of two exact doubles where m <= 2**53 and |e| <= 22 (Clinger
1990, "How to read floating point numbers accurately", the fast path),
else by the Eisel-Lemire algorithm (kernels/parse_float.py: the 17
digits Python's repr writes, as trimesh's ASCII STL has them).  Any
other token (more digits, a subnormal, a product too near halfway, nan,
or not a number at all) is copied out for NumPy's own parser, which
rounds correctly and refuses what is not a number.

One function, written out: each compiled function has a fixed cost, and
split into nine the kernel compiled in five seconds cold (docs/benchmarks.md).
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD
from raytrace.kernels.lowlevel import load_word, trailing_zeros
from raytrace.kernels.parse_float import Q_MAX, Q_MIN, decimal_to_double

# state[]: counts carried from chunk to chunk, and what the caller reads.
NV, NN, NC, NF, LINE, MAXV, MAXV_LINE, MAXN, ALLN, VMAX, NFB, FBLEN = range(12)
ERR, ERR_LINE, ERR_AT, ERR_END = range(12, 16)
# STL (input): read an ASCII STL's "vertex" lines as "v" lines, and count
# its solids in SOLIDS.
STL, SOLIDS = 16, 17
STATE_SIZE = 18
# ERR: the first problem found.
BAD_INDEX, ZERO_INDEX, ZERO_NORMAL, BEFORE_FIRST, SHORT_VERTEX, SHORT_NORMAL, SHORT_FACE, \
    INDEX_TOO_LARGE = range(1, 9)

POW10 = np.array([float(10 ** k) for k in range(23)])    # exact doubles
_EXACT = 1 << 53
_NEWLINES, _ONES, _HIGHS = (np.uint64(0x0A0A0A0A0A0A0A0A), np.uint64(0x0101010101010101),
                            np.uint64(0x8080808080808080))
_INDEX_LIMIT = (1 << 31) - 1
# No reference counting: the kernel allocates nothing.  Without the GIL:
# an ASCII STL's chunk is read in two halves at once (obj._halves).
_KERNEL = dict(BUILD, _nrt=False, nogil=True)


@njit(**_KERNEL)
def parse_lines(buf, n, state, v, vn, cv, cn, fc, fb, slots, pow10, powers):
    """Read the whole lines in buf[:n] (bytes up to 32 but a newline are
    blanks); the counts and the first problem go to ``state``.  Returns 0,
    an error code, or -1 for a file left to trimesh (materials, a line
    continued by a backslash).  A coordinate off the exact path is copied
    to ``fb`` and its place noted in ``slots`` (its flat index in v, or
    minus one minus its flat index in vn)."""
    # The counts in locals while the kernel runs (state[0:12]).
    nv_, nn_, nc_, nf_, line_, maxv_, maxv_line_, maxn_, alln_, vmax_, nfb_, fblen_ = (
        state[0], state[1], state[2], state[3], state[4], state[5], state[6], state[7], state[8],
        state[9], state[10], state[11])
    i = 0
    err = 0
    at = 0
    to = 0
    while i < n and err == 0:
        # The line's end, eight bytes at a time: the lowest byte of x that
        # is zero (a newline in buf) sets the lowest bit of t (Mycroft's
        # test; higher bits of t may be false, and are not used).
        end = i
        while end + 8 <= n:
            x = load_word(buf, end) ^ _NEWLINES
            t = (x - _ONES) & ~x & _HIGHS
            if t != 0:
                end += trailing_zeros(t) >> 3
                break
            end += 8
        while end < n and buf[end] != 10:
            end += 1
        line_ += 1
        stop = end
        while stop > i and buf[stop - 1] <= 32:
            stop -= 1
        if stop > i and buf[stop - 1] == 92:      # a backslash continues the line
            err = -1
            break
        while i < stop and buf[i] <= 32:
            i += 1
        j = i
        while j < stop and buf[j] > 32:
            j += 1
        kind = 0          # 1 v, 2 vn, 3 f; other lines are skipped
        if j - i == 1 and buf[i] == 118:
            kind = 1
        elif j - i == 2 and buf[i] == 118 and buf[i + 1] == 110:
            kind = 2
        elif j - i == 1 and buf[i] == 102:
            kind = 3
        elif state[STL] and j - i == 6 and buf[i] == 118:         # vertex
            kind = 1
        elif state[STL] and j - i == 8 and buf[i] == 101 and buf[i + 3] == 115:    # endsolid
            state[SOLIDS] += 1
        elif j - i == 6 and ((buf[i + 3] == 108 and buf[i + 4] == 105 and buf[i + 5] == 98)
                             or (buf[i + 3] == 109 and buf[i + 4] == 116 and buf[i + 5] == 108)):
            err = -1             # mtllib, usemtl (no other keyword ends so)
            break
        at, to = j, stop
        row = nv_ if kind == 1 else nn_
        count = 0
        i = j
        while kind and err == 0:
            while i < stop and buf[i] <= 32:
                i += 1
            if i >= stop or buf[i] == 35:      # a comment ends the line
                break
            j = i
            while j < stop and buf[j] > 32:
                j += 1
            if kind < 3 and count < 3:
                # [+-]digits[.digits][(e|E)[+-]digits]: m, significant digits,
                # digits after the point, exponent.
                m = 0
                sig = 0
                digits = 0
                frac = 0
                point = False
                neg = buf[i] == 45
                p = i + 1 if buf[i] == 45 or buf[i] == 43 else i
                while p < j:
                    c = buf[p]
                    if 48 <= c <= 57:
                        digits += 1
                        frac += point
                        if m > 0 or c != 48:
                            sig += 1
                            if sig <= 18:
                                m = m * 10 + (c - 48)
                    elif c == 46 and not point:
                        point = True
                    else:
                        break
                    p += 1
                e = 0
                exact = digits > 0 and sig <= 18
                if exact and p < j and (buf[p] == 101 or buf[p] == 69):
                    p += 1
                    eneg = p < j and buf[p] == 45
                    if p < j and (buf[p] == 45 or buf[p] == 43):
                        p += 1
                    exact = p < j
                    while p < j and 48 <= buf[p] <= 57:
                        if e < 100000:
                            e = e * 10 + (buf[p] - 48)
                        p += 1
                    e = -e if eneg else e
                e -= frac
                exact = exact and p == j
                value = 0.0           # pow10 is indexed only on the fast path
                if exact and m != 0 and m <= _EXACT and -22 <= e <= 22:
                    value = m * pow10[e] if e >= 0 else m / pow10[-e]
                elif exact and m != 0:
                    exact = Q_MIN <= e <= Q_MAX
                    if exact:
                        value = decimal_to_double(m, e, powers)
                        exact = value >= 0.0
                if neg:
                    value = -value
                if kind == 1:
                    v[row, count] = value
                else:
                    vn[row, count] = value
                if not exact:
                    k = nfb_
                    slots[k] = row * 3 + count if kind == 1 else -(row * 3 + count) - 1
                    nfb_ = k + 1
                    q = fblen_
                    for h in range(i, j):     # a loop: a slice assignment compiles far longer
                        fb[q] = buf[h]
                        q += 1
                    fb[q] = 32
                    fblen_ = q + 1
            elif kind == 3:
                # A corner: up to three parts split by "/": vertex, texture
                # coordinate (checked, not kept), normal; each [+-]digits.
                part = 0
                val = 0
                nd = 0
                neg = False
                fresh = True
                vi = 0
                ni = 0
                for p in range(i, j + 1):
                    c = 47 if p == j else buf[p]
                    if c == 47:
                        if (nd == 0 and (part == 0 or not fresh)) or part > 2:
                            err = BAD_INDEX
                        if part == 0:
                            vi = -val if neg else val
                        elif part == 2 and nd:
                            ni = -val if neg else val
                            if ni == 0:
                                err = ZERO_NORMAL
                        part += 1
                        val = nd = 0
                        neg = False
                        fresh = True
                    elif (c == 45 or c == 43) and fresh:
                        neg = c == 45
                        fresh = False
                    elif 48 <= c <= 57 and nd < 10:
                        val = val * 10 + (c - 48)
                        nd += 1
                        fresh = False
                    else:
                        err = BAD_INDEX
                if err == 0 and vi == 0:
                    err = ZERO_INDEX
                vi = vi - 1 if vi > 0 else vi + nv_
                if err == 0 and vi < 0:
                    err = BEFORE_FIRST
                if err == 0 and vi > _INDEX_LIMIT:
                    err = INDEX_TOO_LARGE
                if err:
                    at, to = i, j
                    break
                k = nc_
                cv[k] = vi
                if vi > maxv_:
                    maxv_ = vi
                    maxv_line_ = line_
                if ni == 0:
                    cn[k] = -1
                    alln_ = 0
                else:
                    ni = ni - 1 if ni > 0 else ni + nn_
                    # Out of bounds: the normals are all dropped, as trimesh does.
                    cn[k] = ni if 0 <= ni <= _INDEX_LIMIT else _INDEX_LIMIT
                    if cn[k] > maxn_:
                        maxn_ = cn[k]
                nc_ = k + 1
            count += 1
            i = j
        if err:
            break
        if kind == 1:
            if count < 3:
                err = SHORT_VERTEX
            if count > vmax_:
                vmax_ = count
            nv_ += 1
        elif kind == 2:
            if count != 3:
                err = SHORT_NORMAL
            nn_ += 1
        elif kind == 3:
            if count < 3:
                err = SHORT_FACE
            fc[nf_] = count
            nf_ += 1
        i = end + 1
    for k, value in enumerate((nv_, nn_, nc_, nf_, line_, maxv_, maxv_line_, maxn_, alln_, vmax_, nfb_,
                               fblen_)):
        state[k] = value
    if err > 0:
        state[ERR] = err
        state[ERR_LINE] = line_
        state[ERR_AT] = at
        state[ERR_END] = to
    return err
