"""A binary PLY face element of mixed polygons (triangles and quads, say)
read record by record: each record's place depends on every count before
it, so this one loop is serial (scene/formats/ply.py; only such files compile it)."""
from numba import njit

from raytrace.kernels.jit import BUILD


@njit(**BUILD)
def read_uint(buf, pos, size, big):
    value = 0
    for b in range(size):
        byte = buf[pos + b] if big else buf[pos + size - 1 - b]
        value = (value << 8) | byte
    return value


@njit(**BUILD)
def polygon_lists(buf, n, count_size, index_size, index_signed, big, counts, indices):
    """Read n records (a count, then that many indices) from the bytes
    ``buf`` into ``counts`` and ``indices`` (every index in turn).  Returns
    the number of indices, or -1 if the records do not fill ``buf``
    exactly or a count is below 3 (counts are read unsigned: a negative
    one is far too large)."""
    pos = 0
    k = 0
    top = 1 << (8 * index_size - 1)
    for i in range(n):
        if pos + count_size > len(buf):
            return -1
        c = read_uint(buf, pos, count_size, big)
        pos += count_size
        if c < 3 or k + c > len(indices) or pos + c * index_size > len(buf):
            return -1
        counts[i] = c
        for _ in range(c):
            value = read_uint(buf, pos, index_size, big)
            if index_signed and value >= top:
                value -= 2 * top
            indices[k] = value
            k += 1
            pos += index_size
    return k if pos == len(buf) else -1
