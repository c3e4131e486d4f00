"""Equal rows of a key array found with a hash table (open addressing,
linear probing): one pass, where sorting 12.6M corners of an STL took
3 s and gathering them by the sorted order 3 s more (normals._positions,
scene/formats/stl.py)."""
import numpy as np
from numba import njit

from raytrace.kernels.jit import BUILD
from raytrace.kernels.lowlevel import frame_array, prefetch

MIX = np.uint64(0x9E3779B97F4A7C15)


@njit(**dict(BUILD, _nrt=False))
def _row_hash(keys, i):
    # Multiply-xorshift (as in splitmix64): the low bits of a multiply
    # depend only on the low bits of its input, and coordinates read from
    # float32 have 29 zero low bits; the shift folds the high ones down.
    h = np.uint64(0)
    for c in range(keys.shape[1]):
        h = (h ^ np.uint64(keys[i, c])) * MIX
        h ^= h >> np.uint64(29)
    return h


@njit(**dict(BUILD, _nrt=False))
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


# Without the reference-counting runtime (the kernels allocate nothing: a
# grown table comes from first_rows, in Python), and without the GIL (an
# ASCII STL's chunks are welded on a thread of their own).
_KERNEL = dict(BUILD, _nrt=False, nogil=True)


@njit(**_KERNEL)
def moved(table, out, bits):
    """The entries of ``table`` into ``out``, 2^bits slots, all -1: each
    entry's home slot is its tag's top bits, so no row is read again."""
    size = 1 << bits
    for entry in table:
        if entry >= 0:
            slot = (entry >> 32) >> (TAG_BITS - bits)
            while out[slot] >= 0:
                slot = (slot + 1) & (size - 1)
            out[slot] = entry


def new_table(n):
    """An empty table for about ``n`` values (it grows as it fills)."""
    bits = 4
    while bits < TAG_BITS and (1 << bits) < n + n // 2:
        bits += 1
    return np.full(1 << bits, -1, np.int64)


def first_rows(keys, ids, values, table, count):
    """Number the rows of ``keys`` by value, after the ``count`` values
    ``table`` holds already: ids[i] is row i's value's number, in order of
    first appearance, and a new value's row is copied to values[number].
    Returns (table, count), the table grown if it filled.  keys and values:
    (n, w) uint32, rows compared bit for bit; the rows of one mesh file
    may come a chunk at a time (an ASCII STL's).  The kernels run as
    Python for a few rows (kernels/uncompiled.py)."""
    from raytrace.kernels.uncompiled import chosen
    number, move = chosen(number_rows, len(keys)), chosen(moved, len(keys))
    bits = len(table).bit_length() - 1
    start = 0
    while True:
        count, start = number(keys, ids, values, table, bits, count, start)
        if start == len(keys):
            return table, count
        if bits == TAG_BITS:
            raise MemoryError("more distinct rows than a table of 2^31 slots holds")
        bits += 1
        grown = np.full(1 << bits, -1, np.int64)
        move(table, grown, bits)
        table = grown


@njit(**_KERNEL)
def number_rows(keys, ids, values, table, bits, count, start):
    """first_rows's numbering from row ``start``, into ``table`` of 2^bits
    slots, until every row is numbered or the table is two thirds full;
    returns (count, the next row).

    A slot holds a value's number and, above it, 31 high bits of its
    hash (its tag), whose top bits are its home slot: a row is compared
    with a value only where the tags agree, so a probe past another value
    reads no row, and a table grows without reading any."""
    n = keys.shape[0]
    ahead = frame_array(AHEAD, np.int64)       # the tags of rows i .. i + AHEAD - 1
    for i in range(start, min(start + AHEAD, n)):
        ahead[i % AHEAD] = np.int64(_row_hash(keys, i) >> np.uint64(64 - TAG_BITS))
        prefetch(table, ahead[i % AHEAD] >> (TAG_BITS - bits))
    mask = (1 << bits) - 1
    for i in range(start, n):
        tag = ahead[i % AHEAD]
        if i + AHEAD < n:
            later = np.int64(_row_hash(keys, i + AHEAD) >> np.uint64(64 - TAG_BITS))
            ahead[i % AHEAD] = later
            prefetch(table, later >> (TAG_BITS - bits))
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
                    return count, i + 1
                break
            if entry >> 32 == tag and _same_row(keys, i, values, entry & 0xFFFFFFFF):
                ids[i] = entry & 0xFFFFFFFF
                break
            slot = (slot + 1) & mask
    return count, n
