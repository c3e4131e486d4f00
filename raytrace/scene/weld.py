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
def _same_row(keys, i, values, k):
    for c in range(keys.shape[1]):
        if keys[i, c] != values[k, c]:
            return False
    return True


# Rows hashed ahead of the one looked up, their slots prefetched: the
# table and the rows are larger than the caches, so each lookup otherwise
# waits on a load from memory before the next can start.
AHEAD = 16


# A table is sized for the values its caller expects and doubles when two
# thirds full.  A mesh file's corners hold about a sixth as many values as
# rows (each vertex of a closed mesh is a corner of about six triangles:
# an STL's 12.6M corners, 2.1M vertices), and a table sized for the rows
# (2^25 slots, 268 MB) was written once in fresh memory, which costs this
# kind of machine as much as the probes, and missed the cache where one
# sized for the values (33 MB) does not; a PLY's vertices are all distinct
# values, where growing from small took twice as long (docs/benchmarks.md,
# "Mesh files").  FIRST_VALUES: where nothing is known yet (an ASCII STL,
# welded as it is read).
FIRST_VALUES = 1 << 16
TAG_BITS = 31           # a slot's hash bits; the home slot is their top ``bits``


@njit(**dict(BUILD, nogil=True))
def _moved(table, bits):
    """The entries of ``table`` in one of 2^bits slots: each entry's home
    slot is its tag's top bits, so no row is read again."""
    size = 1 << bits
    out = np.full(size, -1, np.int64)
    for entry in table:
        if entry >= 0:
            slot = (entry >> 32) >> (TAG_BITS - bits)
            while out[slot] >= 0:
                slot = (slot + 1) & (size - 1)
            out[slot] = entry
    return out


def new_table(n):
    """An empty table for about ``n`` values (it grows as it fills)."""
    bits = 4
    while bits < TAG_BITS and (1 << bits) < n + n // 2:
        bits += 1
    return np.full(1 << bits, -1, np.int64)


@njit(**dict(BUILD, nogil=True))
def first_rows(keys, ids, values, table, count):
    """Number the rows of ``keys`` by value, after the ``count`` values
    ``table`` holds already: ids[i] is row i's value's number, in order of
    first appearance, and a new value's row is copied to values[number].
    Returns (table, count), the table grown if it filled.  keys and values:
    (n, w) uint32, rows compared bit for bit; the rows of one mesh file
    may come a chunk at a time (an ASCII STL's).

    A slot holds a value's number and, above it, 31 high bits of its
    hash (its tag), whose top bits are its home slot: a row is compared
    with a value only where the tags agree, so a probe past another value
    reads no row, and a table grows without reading any."""
    n = keys.shape[0]
    bits = 0
    while (1 << bits) < len(table):
        bits += 1
    ahead = np.empty(AHEAD, np.int64)           # the tags of rows i .. i + AHEAD - 1
    for i in range(min(AHEAD, n)):
        ahead[i] = np.int64(_row_hash(keys, i) >> np.uint64(64 - TAG_BITS))
        prefetch(table, ahead[i] >> (TAG_BITS - bits))
    for i in range(n):
        tag = ahead[i % AHEAD]
        if i + AHEAD < n:
            later = np.int64(_row_hash(keys, i + AHEAD) >> np.uint64(64 - TAG_BITS))
            ahead[i % AHEAD] = later
            prefetch(table, later >> (TAG_BITS - bits))
        mask = (1 << bits) - 1
        slot = tag >> (TAG_BITS - bits)
        while True:
            entry = table[slot]
            if entry < 0:
                table[slot] = (tag << 32) | count
                ids[i] = count
                for c in range(keys.shape[1]):
                    values[count, c] = keys[i, c]
                count += 1
                if 3 * count > 2 << bits:
                    if bits == TAG_BITS:
                        raise MemoryError("more distinct rows than a table of 2^31 slots holds")
                    bits += 1
                    table = _moved(table, bits)
                break
            if entry >> 32 == tag and _same_row(keys, i, values, entry & 0xFFFFFFFF):
                ids[i] = entry & 0xFFFFFFFF
                break
            slot = (slot + 1) & mask
    return table, count
