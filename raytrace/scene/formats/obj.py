"""Wavefront OBJ files read into arrays a chunk of lines at a time
(scene/formats/objtext.py does the reading): ``v`` positions (a fourth
value, w, is ignored), ``vn`` normals, ``f`` faces of any number of
corners in the forms ``a``, ``a/b``, ``a//c`` and ``a/b/c``, negative
indices counting back from the last vertex read so far, comments, blank
lines, CRLF line ends and tabs; ``vt``, ``o``, ``g``, ``s`` and any other
line are skipped.

What trimesh reads differently is left to it (read_obj returns None): a
file that names materials (``mtllib``, ``usemtl``: its parts, textures and
texture coordinates are trimesh's), vertex colours (``v x y z r g b``), and
lines continued with a backslash.  Otherwise the triangles, their corners'
positions and normals are trimesh's, and tests read each layout both ways
(tests/test_obj.py).  Unlike trimesh, a negative index counts back from
the vertices read before its line (the format's rule; trimesh counts from
the file's last vertex), and a damaged file is refused naming its line.

The format: http://paulbourke.net/dataformats/obj/ (Wavefront, 1992).
"""
import os
import re

import numpy as np

from raytrace.errors import RaytraceError
from raytrace.kernels.limits import BYTES_PER_ROW
from raytrace.kernels.parse_float import POWERS_OF_FIVE
from raytrace.kernels.uncompiled import chosen, file_bytes
from raytrace.scene.formats import objtext as T

CHUNK = 1 << 24     # bytes of file read at a time: lines are cut at the last newline
SPLIT_MIN = 1 << 20  # an ASCII STL's chunk of at least this is read in two halves at once
_BOM = b"\xef\xbb\xbf"

_PROBLEMS = {
    T.BAD_INDEX: "{token!r} is not a face corner (a, a/b, a//c or a/b/c of whole numbers)",
    T.BEFORE_FIRST: "face index {token} is out of bounds (before the first of the {nv} vertices "
                    "read so far)",
    T.ZERO_NORMAL: "face uses normal index 0, out of range (OBJ indices start at 1)",
    T.SHORT_VERTEX: "a vertex of fewer than 3 coordinates ({token!r})",
    T.SHORT_NORMAL: "a normal of other than 3 coordinates ({token!r})",
    T.SHORT_FACE: "a face of fewer than 3 corners ({token!r})",
    T.INDEX_TOO_LARGE: "face index {token} is out of bounds (too large)",
}


def _arrays(size):
    """A fresh state and every array at its bound for a file of ``size``
    bytes (a "v" or "f" line takes 8 bytes at least, a corner 2): pages
    never written take no memory."""
    rows = size // 8 + 1
    state = np.zeros(T.STATE_SIZE, np.int64)
    state[T.ALLN], state[T.MAXV], state[T.MAXN] = 1, -1, -1
    index = size // 2 + 1
    return state, (np.empty((rows, 3)), np.empty((rows, 3)), np.empty(index, np.int32),
                   np.empty(index, np.int32), np.empty(rows, np.int32))


def ascii_stl(path):
    """(vertices (n, 3) float64, faces (m, 3) int64) of an ASCII STL's
    triangles, their corners read as an OBJ's "v" lines and welded a chunk
    at a time: equal corners, bit for bit, one vertex, numbered in order of
    first appearance (scene/weld.py).  The corners are never held all at
    once: a 4.2M-triangle file's would be 300 MB of fresh memory, whose
    first writes cost this kind of machine about as much as reading them.
    None for a file left to trimesh: not text starting "solid", several
    solids (trimesh makes each a mesh), or no "vertex" line in lower case."""
    with open(path, "rb") as fh:
        head = fh.read(CHUNK)
    if not head.lstrip().startswith(b"solid") or b"\0" in head:
        return None
    size = os.path.getsize(path)
    state, out = _arrays(size)
    state[T.STL] = 1
    # At their bounds for the file: pages never written take no memory.
    ids = np.empty(size // 8 + 1, np.int64)
    values = np.empty((size // 8 + 1, 6), np.uint32)

    def each_chunk(state, v):
        # This chunk's corners, then the next chunk's in the same rows.
        weld.add(v, int(state[T.NV]))
        state[T.NV] = 0

    with _Welding(ids, values) as weld:
        if _parse(path, state, out, "STL", each_chunk) is None:
            return None
    if state[T.SOLIDS] > 1 or not weld.corners:
        return None
    corners, count = weld.corners, weld.count
    if corners % 3:
        raise RaytraceError(f"{path}: not a readable STL mesh ({corners} vertices, not 3 a facet)")
    return values[:count].view(np.float64).reshape(count, 3), ids[:corners].reshape(-1, 3)


class _Welding:
    """An ASCII STL's corners welded a chunk at a time (scene/weld.py) on a
    thread of their own while the next chunk is read: each chunk's rows
    are copied into one of two buffers taken in turn (the reader writes
    the next chunk's into its own rows) and welded in order by a pool of
    one worker.  ``corners`` and ``count``: rows and values so far, read
    once the block has ended (it waits for the last chunk)."""

    def __init__(self, ids, values):
        from concurrent.futures import ThreadPoolExecutor

        from raytrace.scene import weld
        self.ids, self.values, self.corners = ids, values, 0
        self.table, self.count = weld.new_table(weld.FIRST_VALUES), 0
        self.buffers, self.pending, self.turn = [None, None], [None, None], 0
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="raytrace-weld")

    def add(self, v, k):
        j, self.turn = self.turn, 1 - self.turn
        if self.pending[j] is not None:
            self.pending[j].result()          # its buffer is free (its error raised here)
        if self.buffers[j] is None or len(self.buffers[j]) < k:
            self.buffers[j] = np.empty((k, 3))
        rows = self.buffers[j][:k]
        rows[:] = v[:k]
        self.pending[j] = self.pool.submit(self._weld, rows, self.corners)
        self.corners += k

    def _weld(self, rows, at):
        from raytrace.scene.weld import first_rows
        self.table, self.count = first_rows(rows.view(np.uint32), self.ids[at:at + len(rows)],
                                            self.values, self.table, self.count)

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        self.pool.shutdown(wait=True, cancel_futures=kind is not None)
        if kind is None:
            for job in self.pending:
                if job is not None:
                    job.result()
        return False


def read_obj(path, warn=None):
    """A dict of MeshPart fields (vertices (n, 3) float64, faces (m, 3)
    int64, normals (n, 3) or None) of an OBJ file, or None for a file left
    to trimesh (see the module's docstring).  Vertices no face uses are
    dropped and polygons fanned, as trimesh does."""
    warn = warn or (lambda message: None)
    state, (v, vn, cv, cn, fc) = _arrays(os.path.getsize(path))
    if _parse(path, state, (v, vn, cv, cn, fc), "OBJ") is None:
        return None
    nv, nn, nc, nf = (int(state[k]) for k in (T.NV, T.NN, T.NC, T.NF))
    if state[T.VMAX] > 5:
        return None          # vertex colours: trimesh's reading
    if nf and state[T.MAXV] >= nv:
        raise RaytraceError(f"{path}: not a readable OBJ mesh (line {state[T.MAXV_LINE]}: face index "
                            f"{state[T.MAXV] + 1} is out of bounds: the file has {nv} vertices)")
    cv, fc = cv[:nc], fc[:nf]
    cn = cn[:nc] if state[T.ALLN] and nf else None
    if cn is not None and state[T.MAXN] >= nn:
        warn(f"{os.path.basename(path)}: a face's normal index is out of bounds (the file has "
             f"{nn} normals); the normals are ignored")
        cn = None
    corners = _triangle_corners(fc, nc)
    return _indexed(v[:nv], vn[:nn], cv, cn, corners)


def warm_kernel():
    """Run the kernel on one line, with the argument types a file gives it
    (the command's warmup)."""
    data = np.frombuffer(bytearray(b"v 0 0 0\n"), np.uint8)
    state = np.zeros(T.STATE_SIZE, np.int64)
    rows, index = np.empty((1, 3)), np.empty(1, np.int32)
    T.parse_lines(data, len(data), state, rows, rows, index, index, index, np.empty(4, np.uint8),
                  np.empty(1, np.int64), T.POW10, POWERS_OF_FIVE)


def _parse(path, state, out, fmt, each_chunk=None):
    """Run the kernel over the file a chunk at a time, then
    ``each_chunk(state, v)`` if given; None if the file is left to
    trimesh."""
    v, vn, cv, cn, fc = out
    buf = bytearray(CHUNK)
    fb = np.empty(2 * CHUNK + 2, np.uint8)
    slots = np.empty(CHUNK // 2 + 1, np.int64)
    kept = 0             # bytes of an unfinished line carried to the next chunk
    first = True
    second = {}          # _halves' arrays, kept from chunk to chunk
    with open(path, "rb") as fh:
        while True:
            got = fh.readinto(memoryview(buf)[kept:])
            n = kept + got
            at_end = got == 0 or n < len(buf)
            if first and buf.startswith(_BOM):
                buf[:3] = b"   "       # a byte-order mark (some Windows editors)
            first = False
            cut = n if at_end else buf.rfind(b"\n", 0, n) + 1
            if cut == 0:         # one line longer than the buffer: grow it
                buf.extend(bytes(len(buf)))
                fb = np.empty(2 * len(buf) + 2, np.uint8)
                slots = np.empty(len(buf) // 2 + 1, np.int64)
                kept = n
                continue
            if not state[T.STL] and _names_materials(buf, cut):
                return None
            data = np.frombuffer(buf, np.uint8)[:cut]
            if state[T.STL] and each_chunk is not None and cut >= SPLIT_MIN and _threads() > 1:
                done = _halves(path, fmt, state, out, data, (fb, slots), each_chunk, second)
            else:
                done = _lines(path, fmt, state, out, data, (fb, slots), each_chunk)
            del data
            if done is None:
                return None
            if at_end:
                return state
            kept = n - cut
            buf[:kept] = buf[cut:n]


# A line whose first word is mtllib or usemtl (blanks: bytes up to 32, as
# the kernel reads them).
_MATERIAL_LINE = re.compile(rb"^[\x00-\x09\x0b-\x20]*(?:mtllib|usemtl)(?![^\x00-\x20])", re.M)


def _names_materials(buf, n):
    """Whether buf[:n] has a line naming materials: such a file is
    trimesh's, and found so it needs no kernel, which would take 1.5-2 s
    to compile on a first run to find the same (most OBJ files written by
    modelling tools name materials)."""
    if buf.find(b"mtllib", 0, n) < 0 and buf.find(b"usemtl", 0, n) < 0:
        return False
    return _MATERIAL_LINE.search(memoryview(buf)[:n]) is not None


def _lines(path, fmt, state, out, data, scratch, each_chunk):
    """The kernel over ``data``, whole lines, then the numbers it left,
    then ``each_chunk``; None if the file is left to trimesh."""
    v, vn, cv, cn, fc = out
    fb, slots = scratch
    state[T.NFB] = state[T.FBLEN] = 0
    first_line = int(state[T.LINE]) + 1
    parse = chosen(T.parse_lines, len(data) // BYTES_PER_ROW)   # as Python for a small file
    code = parse(file_bytes(parse, data), len(data), state, v, vn, cv, cn, fc, fb, slots, T.POW10,
                 POWERS_OF_FIVE)
    if code < 0:
        return None
    _exact_fallback(path, fmt, state, (fb, slots, v, vn), (data, first_line))
    if code:
        raise RaytraceError(_problem(path, fmt, state, data))
    if each_chunk is not None:
        each_chunk(state, v)
    return state


def _halves(path, fmt, state, out, data, scratch, each_chunk, reused):
    """_lines of an ASCII STL's chunk in two halves read at once on two
    threads: the first with the file's state into ``out``, the second from
    a fresh state into rows of its own (``reused`` from chunk to chunk), each
    then welded in order (``each_chunk``).  A second half with a problem
    the kernel finds, or an OBJ line, is read again after the first, as
    one thread reads it: the same vertices, counts and messages.  Only
    since a chunk's corners are welded as read does this pay in a whole
    command: the corners of the whole file were fresh memory, whose page
    faults two threads take one at a time (docs/benchmarks.md)."""
    from functools import partial

    from raytrace.kernels.threads import run_on_threads
    half = len(data) // 2
    newlines = np.flatnonzero(data[max(0, half - (1 << 16)):half] == 10)
    if not len(newlines):
        return _lines(path, fmt, state, out, data, scratch, each_chunk)
    mid = max(0, half - (1 << 16)) + int(newlines[-1]) + 1
    first, rest = data[:mid], data[mid:]
    if reused.get("size", -1) < len(rest):      # the arrays at their bound for this half
        reused.update(size=len(rest), arrays=_arrays(len(rest))[1], scratch=(
            np.empty(2 * len(rest) + 2, np.uint8), np.empty(len(rest) // 2 + 1, np.int64)))
    own, own_scratch = reused["arrays"], reused["scratch"]
    own_state = _arrays(0)[0]
    own_state[T.STL] = 1
    codes = [0, 0]

    def parse(k, part, st, arrays, fb_slots):
        codes[k] = T.parse_lines(part, len(part), st, *arrays, *fb_slots, T.POW10, POWERS_OF_FIVE)

    state[T.NFB] = state[T.FBLEN] = 0
    first_line = int(state[T.LINE]) + 1
    run_on_threads([partial(parse, 0, first, state, out, scratch),
                    partial(parse, 1, rest, own_state, own, own_scratch)])
    if codes[0] < 0:
        return None
    _exact_fallback(path, fmt, state, (*scratch, out[0], out[1]), (first, first_line))
    if codes[0]:
        raise RaytraceError(_problem(path, fmt, state, first))
    each_chunk(state, out[0])
    if codes[1] or own_state[T.NN] or own_state[T.NC] or own_state[T.NF]:
        return _lines(path, fmt, state, out, rest, scratch, each_chunk)
    _exact_fallback(path, fmt, own_state, (*own_scratch, own[0], own[1]),
                    (rest, int(state[T.LINE]) + 1))
    state[T.LINE] += own_state[T.LINE]
    state[T.SOLIDS] += own_state[T.SOLIDS]
    state[T.VMAX] = max(state[T.VMAX], own_state[T.VMAX])
    each_chunk(own_state, own[0])
    return state


def _threads():
    import numba
    return numba.get_num_threads()


def _exact_fallback(path, fmt, state, fallback, chunk):
    """Parse the numbers the kernel left (see objtext.py) with NumPy's
    parser and put them in place; a token that is not a number is refused
    naming its line."""
    fb, slots, v, vn = fallback
    k = int(state[T.NFB])
    if not k:
        return
    text = fb[:state[T.FBLEN]].tobytes()
    try:
        values = np.fromstring(text, sep=" ")
    except ValueError:
        values = None
    if values is None or len(values) != k:
        bad = next(t for t in text.split() if not _is_number(t))
        line = _line_of_token(*chunk, bad)
        raise RaytraceError(f"{path}: not a readable {fmt} mesh (line {line}: "
                            f"{bad.decode('utf-8', 'replace')!r} is not a number)")
    s = slots[:k]
    pos = s >= 0
    v.reshape(-1)[s[pos]] = values[pos]
    vn.reshape(-1)[-s[~pos] - 1] = values[~pos]


def _is_number(token):
    try:
        return len(np.fromstring(token, sep=" ")) == 1
    except ValueError:
        return False


def _line_of_token(data, first_line, token):
    """The number of the first line of a chunk, starting at line
    ``first_line``, that holds ``token`` as a word (for a message only)."""
    for k, line in enumerate(data.tobytes().split(b"\n")):
        if token in line.split():
            return first_line + k
    return first_line


def _problem(path, fmt, state, data):
    code = int(state[T.ERR])
    token = data[state[T.ERR_AT]:state[T.ERR_END]].tobytes().decode("utf-8", "replace").strip()
    line = int(state[T.ERR_LINE])
    if code == T.ZERO_INDEX:      # the words of the check trimesh's path runs (mesh.py)
        return (f"{path}: line {line}: face uses vertex index 0, out of range "
                "(OBJ indices start at 1)")
    text = _PROBLEMS[code].format(token=token, nv=int(state[T.NV]))
    return f"{path}: not a readable {fmt} mesh (line {line}: {text})"


def _triangle_corners(counts, n_corners):
    """(m, 3) positions in the corner list of each triangle of the faces,
    or None when every face is a triangle (the corners in order).  Quads
    give (a, b, c) and (c, d, a), all first triangles before any second
    when every face is a quad, and larger polygons fans from their first
    corner, in the file's order: trimesh's triangulation of an OBJ."""
    if not len(counts) or (counts == 3).all():
        return None
    from raytrace.scene.formats.ply import triangulate
    if (counts == 4).all():
        return triangulate(np.arange(n_corners).reshape(-1, 4))
    fans = counts.astype(np.int64) - 2
    starts = np.cumsum(counts, dtype=np.int64) - counts
    first = np.repeat(starts, fans)
    t = np.arange(len(first)) - np.repeat(np.cumsum(fans) - fans, fans)
    tri = np.stack([first, first + t + 1, first + t + 2], axis=1)
    quad = np.repeat(counts == 4, fans)
    second = quad & (t == 1)        # a quad's second triangle is (c, d, a), not a fan's (a, c, d)
    tri[second] = first[second, None] + [2, 3, 0]
    return tri


def _indexed(v, vn, cv, cn, corners):
    """vertices, faces and normals: one vertex for each (position, normal)
    pair the corners use, numbered in order of first use when the pairs
    differ, else the file's vertices with those no face uses dropped."""
    if cn is not None and (len(vn) < len(v) or not np.array_equal(cv, cn)):
        from raytrace.scene.normals import equal_rows
        pairs = np.stack([cv, cn], axis=1)
        ids, used, _ = equal_rows(pairs)
        del pairs
        faces = ids.reshape(-1, 3) if corners is None else ids[corners]
        return dict(vertices=v[used[:, 0]], faces=faces, normals=vn[used[:, 1]])
    faces = cv.reshape(-1, 3).astype(np.int64) if corners is None else cv[corners].astype(np.int64)
    normals = vn[:len(v)] if cn is not None else None
    used = np.zeros(len(v), bool)
    used[cv] = True
    if not used.all():
        index = np.cumsum(used) - 1
        faces = index[faces]
        v = v[used]
        normals = normals[used] if normals is not None else None
    return dict(vertices=v, faces=faces, normals=normals)
