"""Equal rows of a key array found with a hash table (open addressing,
linear probing): one pass, where sorting 12.6M corners of an STL took
3 s and gathering them by the sorted order 3 s more (normals._positions,
scene/formats/stl.py)."""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD
from raytrace.kernels.lowlevel import prefetch

MIX = np.uint64(0x9E3779B97F4A7C15)


@njit(**BUILD)
def _row_hash(keys, i):
    # Multiply-xorshift (as in splitmix64): the low bits of a multiply
    # depend only on the low bits of its input, and coordinates read from
    # float32 have 29 zero low bits; the shift folds the high ones down.
    h = np.uint64(0)
    for c in range(keys.shape[1]):
        h = (h ^ np.uint64(keys[i, c])) * MIX
        h ^= h >> np.uint64(29)
    return h


@njit(**BUILD)
def _same_row(keys, i, j):
    for c in range(keys.shape[1]):
        if keys[i, c] != keys[j, c]:
            return False
    return True


# Rows hashed ahead of the one looked up, their slots prefetched: the
# table and the rows are larger than the caches, so each lookup otherwise
# waits on a load from memory before the next can start.
AHEAD = 16


@njit(**dict(BUILD, nogil=True))
def first_rows(keys, ids, first):
    """ids[i]: the number of row i's value, numbered in order of first
    appearance; first[k]: the first row of value k.  Returns how many
    values there are.  keys: (n, w) uint32, rows compared bit for bit.

    A slot holds a value's number and, above it, 31 high bits of its
    hash: a row is compared with a slot's first row only where those bits
    agree, so a probe past another value reads no row."""
    n = keys.shape[0]
    size = 16
    while size < n + n // 2:
        size *= 2
    mask = np.uint64(size - 1)
    table = np.full(size, -1, np.int64)    # tag << 32 | value number, or -1
    ahead = np.empty(AHEAD, np.uint64)     # the hashes of rows i .. i + AHEAD - 1
    for i in range(min(AHEAD, n)):
        ahead[i] = _row_hash(keys, i)
        prefetch(table, ahead[i] & mask)
    count = 0
    for i in range(n):
        h = ahead[i % AHEAD]
        if i + AHEAD < n:
            later = _row_hash(keys, i + AHEAD)
            ahead[i % AHEAD] = later
            prefetch(table, later & mask)
        tag = np.int64(h >> np.uint64(33))
        slot = h & mask
        while True:
            entry = table[slot]
            if entry < 0:
                table[slot] = (tag << 32) | count
                ids[i] = count
                first[count] = i
                count += 1
                break
            if entry >> 32 == tag:
                k = entry & 0xFFFFFFFF
                if _same_row(keys, i, first[k]):
                    ids[i] = k
                    break
            slot = (slot + np.uint64(1)) & mask
    return count
