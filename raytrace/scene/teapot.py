"""Newell's Utah teapot: 32 bicubic Bezier patches tessellated to triangles."""
import json

import numpy as np

from raytrace.scene.assets import assets_dir


def load_patches():
    """(patches (32, 16) int, control points (306, 3)) from the bundled JSON (z-up)."""
    with (assets_dir() / "teapot_patches.json").open() as fh:
        data = json.load(fh)
    return np.array(data["patches"], dtype=np.int64), np.array(data["vertices"], dtype=np.float64)


def _bernstein(t):
    """Cubic Bernstein basis at parameters t: shape (len(t), 4)."""
    s = 1.0 - t
    return np.stack([s ** 3, 3 * t * s ** 2, 3 * t ** 2 * s, t ** 3], axis=1)


def tessellate(detail=4):
    """Tessellate each patch into detail x detail quads (2 triangles each).

    Returns (vertices, faces, normals) in the teapot's own z-up frame.
    detail=4 gives 1,024 triangles, the workshop's model size; the pole
    triangles (the lid knob and the bottom centre, where a patch edge
    collapses to a point) are degenerate and dropped when the scene is
    flattened.  Vertices along shared patch edges are welded so smooth
    normals run across the seams.
    """
    if detail < 1:
        raise ValueError("teapot detail must be at least 1")
    patches, cps = load_patches()
    b = _bernstein(np.linspace(0.0, 1.0, detail + 1))
    ctrl = cps[patches].reshape(-1, 4, 4, 3)
    if _takes_kernels(len(patches), detail):
        return _tessellate_parallel(b, ctrl, detail, _threads())
    n1 = detail + 1
    verts = _surface_points(b, ctrl).reshape(-1, 3)
    idx = np.arange(n1 * n1).reshape(n1, n1)
    a, bq, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    # Wound so normals point out of the teapot (Newell's patches run the
    # other way: with (a, b, c) the signed volume comes out negative).
    quad = np.stack([np.stack([a, c, bq], -1), np.stack([a, d, c], -1)], axis=2).reshape(-1, 3)
    faces = (quad[None, :, :] + (np.arange(len(patches)) * n1 * n1)[:, None, None]).reshape(-1, 3)
    verts, faces, n_seam = _weld(verts, faces, _seam_rows(len(patches), n1))
    return verts, faces, _vertex_normals(verts, faces, n_seam, len(patches), detail)


# From this many triangles on (--detail 125 and up), tessellate on every
# thread (scene/tessellate.py): in NumPy, most of the time goes to faulting
# in its temporaries' fresh pages.  Smaller teapots, quick in NumPy, do not
# compile the kernels (docs/benchmarks.md, "Scene").
KERNEL_MIN = 1_000_000


def load_kernels(detail):
    """Seconds spent loading (or compiling) scene/tessellate.py if
    tessellate(detail) will use it; 0.0 otherwise."""
    patches, cps = load_patches()
    if not _takes_kernels(len(patches), detail):
        return 0.0
    import time

    # Importing the kernels' module imports Numba (0.3-0.6 s): loading's time, not compiling's.
    import raytrace.scene.tessellate  # noqa: F401
    t0 = time.perf_counter()
    _tessellate_parallel(_bernstein(np.linspace(0.0, 1.0, 3)), cps[patches].reshape(-1, 4, 4, 3),
                         2, 1)
    return time.perf_counter() - t0


def _takes_kernels(n_patches, detail):
    """Whether tessellate(detail) runs scene/tessellate.py."""
    return 2 * n_patches * detail * detail >= KERNEL_MIN


def _threads():
    import numba
    return numba.get_num_threads()


def _tessellate_parallel(b, ctrl, detail, threads):
    """tessellate's (vertices, faces, normals), the same bits, made by
    scene/tessellate.py on ``threads`` threads.  Only the patch edges'
    points are computed in NumPy first (_surface_points on their (u, v)
    pairs alone: the same sums), to weld them; the interior's go straight
    to their welded rows."""
    from functools import partial

    from raytrace.kernels.threads import run_on_threads, runs
    from raytrace.scene.tessellate import (
        face_normals,
        grid_faces,
        interior_normals,
        interior_points,
        seam_normals,
    )
    n_patches, n1 = len(ctrl), detail + 1
    edge = _seam_rows(1, n1)                  # the (u, v) pairs on a patch's edge
    seam_pts = _surface_points(b, ctrl, at=edge)
    seam_verts, seam_index = _weld_rows(seam_pts.reshape(-1, 3))
    n_seam = len(seam_verts)
    # grid vertex -> its number
    welded, _ = _vertex_numbers(n_patches * n1 * n1, _seam_rows(n_patches, n1), seam_index, n_seam)
    verts = np.empty((n_seam + n_patches * (n1 - 2) ** 2, 3))
    verts[:n_seam] = seam_verts
    weight, ctrl16 = _weights(b), _control_rows(ctrl)
    patch_runs = runs(n_patches, threads)
    faces = np.empty((2 * n_patches * detail * detail, 3), np.int64)

    def points_and_faces(first, last):
        interior_points(weight, ctrl16, n1, n_seam, first, last, verts)
        grid_faces(welded, n1, first, last, faces)
    run_on_threads([partial(points_and_faces, s, e) for s, e in patch_runs])
    fn = np.empty(faces.shape)
    run_on_threads([partial(face_normals, verts, faces, s, e, fn)
                    for s, e in runs(len(faces), threads)])
    normals = np.empty_like(verts)
    run_on_threads([partial(seam_normals, fn, faces, n_seam, np.zeros((n_seam, 3)), normals)]
                   + [partial(interior_normals, fn, n1, n_seam, s, e, normals)
                      for s, e in patch_runs])
    return verts, faces, normals


_ROWS = 1024      # (u, v) pairs a block: 96 of them a pair, so 786 KB of float64 a block


def _weights(b):
    """(n1 * n1, 16): B_i(u) B_j(v) for each (u, v) pair, ij = 4 i + j."""
    n1 = len(b)
    return (b[:, None, :, None] * b[None, :, None, :]).reshape(n1 * n1, 16)


def _control_rows(ctrl):
    """(16, patches * 3): control point ij of every patch, a row each."""
    return ctrl.reshape(len(ctrl), 16, 3).transpose(1, 0, 2).reshape(16, len(ctrl) * 3)


def _surface_points(b, ctrl, at=None):
    """P(u, v) = sum_ij B_i(u) B_j(v) C_ij for every patch: (P, n+1, n+1, 3),
    or with ``at`` (flat (u, v) indices) (P, len(at), 3).

    The sum of np.einsum("ui,vj,pijk->puvk", b, b, ctrl), term for term and
    in its order ((B_i(u) B_j(v)) C_ij, i then j, from 0.0), so the same
    bits, computed _ROWS (u, v) pairs at a time for every patch: 16 passes
    over a block that stays in L2 cache instead of einsum's loop
    (docs/benchmarks.md, "Scene").
    """
    n1, n_patches = len(b), len(ctrl)
    weight = _weights(b)
    if at is not None:
        weight = weight[at]
    ctrl = _control_rows(ctrl)
    points = np.zeros((len(weight), n_patches * 3))
    term = np.empty((min(_ROWS, len(weight)), n_patches * 3))
    for s in range(0, len(weight), _ROWS):
        block = points[s:s + _ROWS]
        t = term[:len(block)]
        for ij in range(16):
            np.multiply(weight[s:s + _ROWS, ij, None], ctrl[ij], out=t)
            block += t
    if at is not None:
        return points.reshape(len(weight), n_patches, 3).transpose(1, 0, 2)
    return points.reshape(n1, n1, n_patches, 3).transpose(2, 0, 1, 3)


def _seam_rows(n_patches, n1):
    """Rows of the patches' (n1 x n1) vertex grids that lie on a patch edge,
    in row order: the only vertices another patch can share."""
    edge = np.ones((n1, n1), bool)
    edge[1:-1, 1:-1] = False
    return (np.flatnonzero(edge)[None, :] + (np.arange(n_patches) * n1 * n1)[:, None]).reshape(-1)


def _weld(verts, faces, seams):
    """Merge coincident vertices (patch seams) so normals average across them.

    Only the rows in ``seams`` (patch edges, 1.6% of the vertices at detail
    256) are compared: Newell's patches meet edge to edge, and a grid's
    interior vertices are its own; welding every row instead (np.unique)
    was a large share of a big tessellation.  Welded seam
    vertices come first, then the interior ones in row order
    (_vertex_normals relies on it).  Nothing else depends on the vertices'
    order: faces keep theirs.
    """
    welded, seam_index = _weld_rows(verts[seams])
    n_seam = len(welded)
    inverse, inside = _vertex_numbers(len(verts), seams, seam_index, n_seam)
    welded = np.concatenate([welded, verts[inside]])
    return welded, inverse[faces], n_seam


def _vertex_numbers(n_rows, seams, seam_index, n_seam):
    """(each unwelded row's welded vertex number, which rows are not on a
    seam): seam row k is welded vertex seam_index[k]; the others follow
    the n_seam welded ones, in row order."""
    inside = np.ones(n_rows, bool)
    inside[seams] = False
    numbers = np.empty(n_rows, np.int64)
    numbers[seams] = seam_index
    numbers[inside] = n_seam + np.arange(n_rows - len(seams))
    return numbers, inside


def _weld_rows(rows):
    """(the distinct rows, each row's number among them): rows equal when
    rounded to 9 decimals are one, whose value is the last of them.

    Each rounded row as one 24-byte value: np.unique then sorts bytes, not
    rows of floats; + 0.0 makes -0.0 equal 0.0.
    """
    key = np.ascontiguousarray(np.round(rows, 9) + 0.0)
    keys = key.view(np.dtype((np.void, key.itemsize * 3))).reshape(-1)
    _, index = np.unique(keys, return_inverse=True)
    index = index.reshape(-1)
    welded = np.empty((int(index.max()) + 1 if len(index) else 0, 3))
    welded[index] = rows       # the last of each group is written last
    return welded, index


_CHUNK = 1 << 18


def _vertex_normals(verts, faces, n_seam, n_patches, detail):
    """Area-weighted average of face normals around each vertex.

    The sums are np.add.at's over the faces' corners, corner by corner, term
    by term in the same order (so the same bits): np.bincount for the
    welded seam vertices (the first n_seam), and for the rest, a grid's
    interior, the six triangles around each taken from the face grid by
    slicing, in the order bincount would add them (bincount over every
    corner is slower).  Everything runs a coordinate at a time, on (faces,)
    and (vertices,) rows: NumPy's loops over rows of 3 (np.cross, norm
    along axis 1, slices of (..., 2, 3) face grids) are slow.
    """
    corners = np.ascontiguousarray(faces.T)     # np.take on contiguous rows: fast gathers
    xyz = np.ascontiguousarray(verts.T)
    # Face normals a chunk of faces at a time (the corners and edges of all
    # faces at once are hundreds of MB of temporaries), np.cross's
    # products and differences in its order, so the same bits.
    fn = np.empty((3, len(faces)))
    for s in range(0, len(faces), _CHUNK):
        c = slice(s, s + _CHUNK)
        p0, p1, p2 = ([np.take(xyz[a], corners[k, c]) for a in range(3)] for k in range(3))
        e1 = [p1[a] - p0[a] for a in range(3)]
        e2 = [p2[a] - p0[a] for a in range(3)]
        for a in range(3):
            b, d = (a + 1) % 3, (a + 2) % 3
            np.multiply(e1[b], e2[d], out=fn[a, c])
            fn[a, c] -= e1[d] * e2[b]
    vn = np.empty((3, len(verts)))
    at = np.flatnonzero(corners.reshape(-1) < n_seam)   # corner k of face i is at k * len(faces) + i
    seam, face = corners.reshape(-1)[at], at % len(faces)
    # Interior vertex (x, y) of a patch is corner 0 of both triangles of
    # quad (x, y) (a, tessellate's names), corner 1 of triangle 0 of quad
    # (x-1, y-1) (c) and of triangle 1 of (x, y-1) (d), and corner 2 of
    # triangle 1 of (x-1, y-1) (c) and of triangle 0 of (x-1, y) (b); faces
    # run quad by quad, row by row.  0.0 + starts the sum as bincount does.
    for a in range(3):
        vn[a, :n_seam] = np.bincount(seam, weights=fn[a, face], minlength=n_seam)
        tri = fn[a].reshape(n_patches, detail, detail, 2)
        t0, t1 = tri[..., 0], tri[..., 1]
        inner = vn[a, n_seam:].reshape(n_patches, detail - 1, detail - 1)
        np.add(0.0, t0[:, 1:, 1:], out=inner)
        inner += t1[:, 1:, 1:]
        inner += t0[:, :-1, :-1]
        inner += t1[:, 1:, :-1]
        inner += t1[:, :-1, :-1]
        inner += t0[:, :-1, 1:]
    # np.linalg.norm's sum along a row, ((x^2 + y^2) + z^2): the same bits.
    ln = np.sqrt(vn[0] * vn[0] + vn[1] * vn[1] + vn[2] * vn[2])
    out = np.zeros_like(verts)
    for a in range(3):
        np.divide(vn[a], ln, out=out[:, a], where=ln > 0)
    return out
