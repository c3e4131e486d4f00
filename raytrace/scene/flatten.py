"""Scene -> kernel buffers (structure of arrays, fixed dtypes)."""
import functools

import numpy as np

from raytrace.errors import RaytraceError
from raytrace.kernels.buffers import N_MAT_PARAMS, Geometry, f64, i64
from raytrace.kernels.pages import lazy_zeros, small_pages
from raytrace.scene.model import Camera, Mesh, Plane, Scene, Sphere

# A triangle whose doubled area is below this fraction of its longest edge
# squared is degenerate (zero area, collinear, or a repeated vertex): it has
# no normal, so it is dropped at load and counted.  1e-14 is ~50 ulps of
# float64 -- rounding in the cross product, not a real sliver (a 1e-6 aspect
# sliver keeps a ratio of ~1e-6 and stays).
DEGENERATE_RATIO = 1e-14
DEGENERATE_CHUNK = 1 << 18      # triangles tested at a time (mesh_triangles)
# From this many faces on, a mesh's corners are gathered and tested on
# every thread (scene/corners.py), as the BVH builds from this size on
# (accel/bvh/build.py): smaller meshes' first render does not compile it.
PARALLEL_MIN = 100_000


def cross_rows(a, b):
    """Row-wise cross products of two (n, 3) arrays: np.cross's arithmetic
    (a_i b_j - a_j b_i), the same bits, without its axis handling (which
    dominated a one-ray query's normal)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        out[:, k] = a[:, i] * b[:, j] - a[:, j] * b[:, i]
    return out


def unit_rows(v):
    """Each row of an (n, 3) array scaled to unit length (zero rows stay
    zero).  Where the squares over- or underflow (coordinates near the 1e100
    limit) a row is first divided by its largest component; other rows are
    divided by np.linalg.norm's own sum, so their results are unchanged."""
    with np.errstate(over="ignore", under="ignore"):   # the rows handled below
        # ((x^2 + y^2) + z^2), as np.add.reduce(v * v, axis=1) adds them (the
        # same bits), a column at a time: a third of the reduction's time.
        sq = np.zeros(0)
        if len(v):
            sq = v[:, 0] * v[:, 0]
            sq += v[:, 1] * v[:, 1]
            sq += v[:, 2] * v[:, 2]
    ok = (sq > 1e-290) & (sq < 1e290)
    if ok.all():                 # the usual case, without the masks' copies
        return v / np.sqrt(sq)[:, None]
    # Every row divided, then the few others redone: masks over a big
    # array's rows (a mesh with a zero normal) cost several times the
    # division.  The kept rows' quotients are the same either way.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        out = v / np.sqrt(sq)[:, None]
    bad = np.flatnonzero(~ok)
    rows = v[bad]
    out[bad] = 0.0
    odd = np.abs(rows).max(axis=1, initial=0.0) > 0
    if odd.any():
        w = rows[odd] / np.abs(rows[odd]).max(axis=1, keepdims=True)
        out[bad[odd]] = w / np.sqrt(np.add.reduce(w * w, axis=1))[:, None]
    return out


def _longest2(e1, e2, e3):
    """Each triangle's longest edge, squared (np.maximum: no stacked copy)."""
    d = [np.einsum("ij,ij->i", e, e) for e in (e1, e2, e3)]
    return np.maximum(np.maximum(d[0], d[1]), d[2])


def degenerate_mask(v0, v1, v2):
    e1 = v1 - v0
    e2 = v2 - v0
    e3 = v2 - v1
    with np.errstate(over="ignore"):
        longest2 = _longest2(e1, e2, e3)
    # The area's square is about longest2 squared: outside this range it
    # over- or underflows, so compare the edges scaled by their largest
    # component (the ratio does not change); other rows are divided by 1,
    # so their results are unchanged.
    odd = ~((longest2 > 1e-140) & (longest2 < 1e140))
    if odd.any():
        s = np.ones(len(e1))
        s[odd] = np.max([np.abs(e[odd]).max(axis=1, initial=0.0) for e in (e1, e2, e3)], axis=0)
        s[s == 0] = 1.0
        e1, e2, e3 = (e / s[:, None] for e in (e1, e2, e3))
        longest2 = _longest2(e1, e2, e3)
    area2 = np.linalg.norm(cross_rows(e1, e2), axis=1)
    return ~(area2 > DEGENERATE_RATIO * longest2)


def _check_finite(name, arr):
    if not np.all(np.isfinite(arr)):
        raise RaytraceError(f"{name}: coordinates contain NaN or inf")


def mesh_triangles(mesh, shading=True):
    """(v0, v1, v2, normals, corners, kept, faces) of a mesh, degenerates
    removed: normals (k, 3) unit shading normals and corners (n, 3) each
    triangle's rows of them (the mesh's vertex normals, or a flat mesh's
    face normals, one row a triangle), both None without ``shading``;
    kept holds the indices into mesh.faces of the triangles returned,
    faces their vertex indices."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise RaytraceError(f"{mesh.name}: vertices must have shape (n, 3), got {v.shape}")
    if f.size and (f.ndim != 2 or f.shape[1] != 3):
        raise RaytraceError(f"{mesh.name}: faces must have shape (m, 3), got {f.shape}")
    f = f.reshape(-1, 3)
    if f.size and not np.issubdtype(f.dtype, np.integer):
        raise RaytraceError(f"{mesh.name}: face indices must be integers")
    f = f.astype(np.int64, copy=False)
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise RaytraceError(
            f"{mesh.name}: face index out of range (mesh has {len(v)} vertices, "
            f"indices span {f.min()}..{f.max()})")
    _check_finite(mesh.name, v)
    v0, v1, v2, keep = _kept_corners(v, f)
    kept = np.flatnonzero(keep)
    if not shading:
        return v0, v1, v2, None, None, kept, _kept_faces(f, kept, len(v))
    # Made unit here, a second time for normals that scene/normals.py made unit
    # (a pass that may move a last bit; the images and exact counters are
    # made with it).  Per vertex, then gathered: per-corner results at a
    # sixth of the work.  Before the kept faces are copied: this is
    # flattening's peak for a big mesh.
    if mesh.normals is not None:
        nrm = unit_rows(np.asarray(mesh.normals, dtype=np.float64))
        taken = _kept_faces(f, kept, len(v))
        # The normals' row numbers are int32 (flatten), an array of the
        # caller's own: it adds its offset in place.
        at = taken if taken is not f and taken.dtype == np.int32 else taken.astype(np.int32)
        f = taken
    else:
        nrm = unit_rows(unit_rows(cross_rows(v1 - v0, v2 - v0)))
        f = _kept_faces(f, kept, len(v))
        at = np.repeat(np.arange(len(f), dtype=np.int32), 3).reshape(-1, 3)
    return v0, v1, v2, nrm, at, kept, f


def _kept_faces(f, kept, n_vertices):
    """The rows ``kept`` of the (m, 3) int64 faces ``f``: ``f`` itself if
    every row is kept, else a new array, int32 where n_vertices fit (half
    the bytes, a chunk at a time: no int64 copy of a big mesh's faces).
    np.take of rows, not f[keep]: a boolean mask over rows of 3 is several
    times slower."""
    if len(kept) == len(f):
        return f
    if n_vertices <= 2**31:
        out = np.empty((len(kept), 3), np.int32)
        for k in range(0, len(kept), DEGENERATE_CHUNK):
            out[k:k + DEGENERATE_CHUNK] = np.take(f, kept[k:k + DEGENERATE_CHUNK], axis=0)
        return out
    return np.take(f, kept, axis=0)


def _kept_corners(v, f):
    """(v0, v1, v2, keep): the corners of the triangles that are not
    degenerate, and which those are.  Big meshes on every thread
    (_kept_corners_parallel); else a chunk at a time: gathered, tested,
    and its kept rows written on, so neither the test's temporaries (5
    times the triangles' size) nor a second, filtered copy of the corners
    is ever made; the outputs are views of buffers whose unused tail is
    never touched, so it takes no memory."""
    n = len(f)
    # Each corner's indices contiguous: np.take then gathers several times
    # faster than indexing with a strided column.
    corners = np.ascontiguousarray(f.T)
    threads = _corner_threads(n)
    if threads:
        return _kept_corners_parallel(v, corners, threads)
    out = [np.empty((n, 3)) for _ in range(3)]
    keep = np.empty(n, bool)
    m = 0
    for k in range(0, n, DEGENERATE_CHUNK):
        c = slice(k, k + DEGENERATE_CHUNK)
        a = [np.take(v, corners[i, c], axis=0) for i in range(3)]
        ok = keep[c] = ~degenerate_mask(*a)
        j = int(np.count_nonzero(ok))
        for dst, src in zip(out, a):
            dst[m:m + j] = src if j == len(ok) else src[ok]
        m += j
    return out[0][:m], out[1][:m], out[2][:m], keep


def _corner_threads(n_faces):
    """Threads for a mesh of n_faces faces' corners: Numba's, from
    PARALLEL_MIN faces on and with more than one; else 0 (the NumPy path)."""
    if n_faces < PARALLEL_MIN:
        return 0
    import numba
    threads = numba.get_num_threads()
    return threads if threads > 1 else 0


def load_corners(scene):
    """Seconds spent loading (or compiling) scene/corners.py if the scene
    has a mesh that will use it, so that flattening's time is not compile
    time (driver.prepare); 0.0 otherwise."""
    if not any(isinstance(o, Mesh) and _corner_threads(np.asarray(o.faces).size // 3)
               for o in scene.objects):
        return 0.0
    import time
    t0 = time.perf_counter()
    v, corners = np.zeros((1, 3)), np.zeros((3, 1), np.int64)
    _kept_corners_parallel(v, corners, 1)
    return time.perf_counter() - t0


def _kept_corners_parallel(v, corners, threads):
    """_kept_corners on ``threads`` threads (scene/corners.py): each takes
    a run of faces, tests them, then writes its kept corners where the runs
    before it end.  The few rows too large or small to test as they are
    (ODD) are tested by degenerate_mask between the two steps."""
    from functools import partial

    from raytrace.kernels.threads import run_on_threads, runs
    from raytrace.scene.corners import DROPPED, KEPT, ODD, classify, gather
    v = np.ascontiguousarray(v)        # one layout: the kernels compile once (load_corners)
    faces = runs(corners.shape[1], threads)
    state = np.empty(corners.shape[1], np.uint8)
    run_on_threads([partial(classify, v, corners, DEGENERATE_RATIO, s, e, state)
                    for s, e in faces])
    odd = np.flatnonzero(state == ODD)
    if len(odd):
        dropped = degenerate_mask(*(v[corners[i, odd]] for i in range(3)))
        state[odd] = np.where(dropped, DROPPED, KEPT)
    keep = state == KEPT
    rows = np.cumsum([0] + [np.count_nonzero(keep[s:e]) for s, e in faces]).tolist()
    out = [np.empty((rows[-1], 3)) for _ in range(3)]
    run_on_threads([partial(gather, v, corners, state, s, e, rows[k], *out)
                    for k, (s, e) in enumerate(faces)])
    return (*out, keep)


@small_pages()    # write-once arrays: no huge-page advice (kernels/pages.py)
def flatten(scene, with_sources=False, shading=True):
    """Returns (Geometry, obj_ranges, info), and with ``with_sources`` also
    (prim_object, prim_index).  Without ``shading`` (ray queries, which
    never shade) the meshes' shading normals, colours and texture
    coordinates are left out: empty arrays (the normals are half of
    flattening's time).

    obj_ranges[j] = (first unified primitive id, count) of bounded object j
    (each mesh, each sphere), for per-object bounding volumes.  info holds
    counts for the statistics (triangles, dropped degenerates, ...).
    prim_object[p] is the index in scene.objects of unified primitive p and
    prim_index[p] its face's index in that mesh's own faces array (0 for a
    sphere or plane): degenerate faces are dropped here, so kernel ids need
    this map to name the user's faces.
    """
    materials, mat_index = [], {}

    def mat_id(m):
        if id(m) not in mat_index:
            mat_index[id(m)] = len(materials)
            materials.append(m)
        return mat_index[id(m)]

    tris = [[] for _ in range(3)]
    normals, normal_at = [], []     # per mesh: unit normals, and each triangle's rows of them
    n_normals = 0
    mesh_mat, obj_ranges = [], []    # per mesh: its material's id
    # Per mesh: per-vertex colours and texture coordinates (or None), and
    # its vertices' count; tri_vertex (below) indexes them.
    colors, uvs, n_vertices = [], [], []
    corner_rows = _vertex_rows(scene, shading)
    vertex_rows = 0        # sum(n_vertices), kept as it grows
    spheres, planes = [], []
    tri_src, sph_src, pl_src = [], [], []   # (object index, face index) per primitive
    dropped = n_tris = 0
    for j, obj in enumerate(scene.objects):
        if isinstance(obj, Mesh):
            v0, v1, v2, nrm, at, kept, faces = mesh_triangles(obj, shading)
            dropped += len(np.asarray(obj.faces).reshape(-1, 3)) - len(kept)
            k = len(v0)
            if k:
                for dst, src in zip(tris, (v0, v1, v2)):
                    dst.append(src)
                mesh_mat.append(mat_id(obj.material))
                colors.append(_vertex_values(obj, "colors", 3) if shading else None)
                # Texture coordinates only where a texture uses them.
                textured = shading and getattr(obj.material, "texture", None) is not None
                if textured and obj.uv is None:
                    raise RaytraceError(f"{obj.name}: its material has a texture but the mesh "
                                        "has no texture coordinates (uv)")
                uvs.append(_vertex_values(obj, "uv", 2) if textured else None)
                if corner_rows is not None:       # before ``at`` (maybe ``faces``) is offset
                    rows = faces.astype(np.int32)     # a copy: ``faces`` stays as it is
                    rows += np.int32(vertex_rows)
                    corner_rows.append(rows)
                n_vertices.append(len(np.asarray(obj.vertices).reshape(-1, 3)))
                vertex_rows += n_vertices[-1]
                if shading:
                    normals.append(nrm)
                    # int32 rows of this mesh's own (mesh_triangles; they may
                    # be ``faces``, used above), offset in place: no copy.
                    at += np.int32(n_normals)
                    normal_at.append(at)
                    n_normals += len(nrm)
                if with_sources:      # RayScene's map back to the user's faces only
                    tri_src.append(np.stack([np.full(k, j), kept], axis=1))
                obj_ranges.append((n_tris, k))
                n_tris += k
        elif isinstance(obj, Sphere):
            _check_finite("sphere", np.array([*obj.center, obj.radius], dtype=float))
            if not obj.radius > 0:
                raise RaytraceError(f"sphere radius must be positive, got {obj.radius}")
            spheres.append(obj)
            sph_src.append((j, 0))
        elif isinstance(obj, Plane):
            n = np.asarray(obj.normal, dtype=float)
            _check_finite("plane", np.concatenate([n, np.asarray(obj.point, dtype=float)]))
            if not np.linalg.norm(n) > 0:
                raise RaytraceError("plane normal must be non-zero")
            planes.append(obj)
            pl_src.append((j, 0))
        else:
            raise RaytraceError(f"unknown scene object {type(obj).__name__}")
    for j in range(len(spheres)):
        obj_ranges.append((n_tris + j, 1))

    def cat(parts):
        if len(parts) == 1:           # one mesh: its arrays as they are, not a copy
            return f64(parts[0], 3)
        return f64(np.concatenate(parts) if parts else np.zeros((0, 3)), 3)

    if not materials:
        mat_id(scene.objects[0].material if scene.objects else _default_material())
    pl_n = unit_rows(np.array([p.normal for p in planes], dtype=float).reshape(-1, 3))
    # Unit already (mesh_triangles); a zero one falls back to the face normal
    # in the kernels.  int32 rows: 2^31 normals, far past any memory here.
    if n_normals >= 2**31:
        raise RaytraceError(f"{n_normals:,} vertex normals: more than this renderer indexes")
    tri_normal = (normal_at[0] if len(normal_at) == 1 else np.ascontiguousarray(
        np.concatenate(normal_at) if normal_at else np.zeros((0, 3)), dtype=np.int32))
    mat_tex, tex_rgb = _textures(materials)
    # Zeros never written: material 0's triangles (a mesh file's all) cost no memory.
    tri_mat = lazy_zeros(n_tris, np.int64)
    for (first, k), m in zip(obj_ranges, mesh_mat):
        if m:
            tri_mat[first:first + k] = m
    geo = Geometry(
        tri_v0=cat(tris[0]), tri_v1=cat(tris[1]), tri_v2=cat(tris[2]),
        vtx_normal=cat(normals), tri_normal=tri_normal.reshape(-1, 3),
        tri_mat=tri_mat,
        tri_vertex=_tri_vertex(corner_rows, tri_normal, colors, uvs),
        vtx_color=_vertex_buffer(colors, n_vertices, 3, 1.0),
        vtx_uv=_vertex_buffer(uvs, n_vertices, 2, 0.0),
        sph_center=f64([s.center for s in spheres], 3),
        sph_radius=f64([s.radius for s in spheres]).reshape(-1),
        sph_mat=i64([mat_id(s.material) for s in spheres]),
        pl_point=f64([p.point for p in planes], 3),
        pl_normal=f64(pl_n, 3),
        pl_mat=i64([mat_id(p.material) for p in planes]),
        mat_color=f64([m.color for m in materials], 3),
        mat_param=f64([[m.ambient, m.diffuse, m.specular, m.shininess, m.checker, m.reflect,
                        m.transmit, m.ior, *m.emission, m.glossy] for m in materials],
                       N_MAT_PARAMS),
        mat_tex=mat_tex, tex_rgb=tex_rgb,
    )
    info = {"triangles": n_tris, "degenerate_dropped": dropped,
            "spheres": len(spheres), "planes": len(planes), "objects": len(obj_ranges)}
    ranges = np.array(obj_ranges, dtype=np.int64).reshape(-1, 2)
    if not with_sources:
        return geo, ranges, info
    src = np.concatenate([*tri_src, np.array(sph_src + pl_src, dtype=np.int64).reshape(-1, 2)])
    src = src.astype(np.int64).reshape(-1, 2)
    return geo, ranges, info, (src[:, 0].copy(), src[:, 1].copy())


def _default_material():
    from raytrace.scene.model import Material
    return Material()


def _vertex_values(mesh, attr, cols):
    """A mesh's per-vertex ``colors`` or ``uv``, (n, cols) float64, or None
    if it has none."""
    values = getattr(mesh, attr, None)
    if values is None:
        return None
    a = np.asarray(values, dtype=np.float64)
    n = len(np.asarray(mesh.vertices).reshape(-1, 3))
    if a.shape != (n, cols):
        raise RaytraceError(f"{mesh.name}: {attr} must have shape ({n}, {cols}), one row per "
                            f"vertex, got {a.shape}")
    if not np.isfinite(a).all():
        raise RaytraceError(f"{mesh.name}: {attr} contain NaN or inf")
    if attr == "colors" and (a < 0).any():
        raise RaytraceError(f"{mesh.name}: colors must not be negative")
    return a


def _vertex_rows(scene, shading):
    """A list to gather each mesh's kept faces into, offset to rows of
    the vertex buffers, where they are needed and are not tri_normal: some
    mesh has colours or a texture, and some mesh's normal rows are not its
    vertices (none in the file: face normals).  Else None."""
    meshes = [o for o in scene.objects if isinstance(o, Mesh)]
    if not shading or not any(getattr(o, "colors", None) is not None
                              or getattr(o.material, "texture", None) is not None
                              for o in meshes):
        return None
    if all(o.normals is not None and len(np.asarray(o.normals).reshape(-1, 3))
           == len(np.asarray(o.vertices).reshape(-1, 3)) for o in meshes):
        return None
    return []


def _tri_vertex(corner_rows, tri_normal, colors, uvs):
    """Each triangle's corners' rows of vtx_color and vtx_uv: tri_normal
    itself where every mesh's normals are its vertices' (the same rows);
    (0, 3) if no mesh has colours or texture coordinates."""
    if all(v is None for v in colors) and all(v is None for v in uvs):
        return np.zeros((0, 3), np.int32)
    if corner_rows is None:
        return tri_normal.reshape(-1, 3)
    return np.ascontiguousarray(np.concatenate(corner_rows).reshape(-1, 3), np.int32)


def _vertex_buffer(per_mesh, n_vertices, cols, fill):
    """The (k, cols) per-vertex buffer over all meshes, ``fill`` for meshes
    without values; (0, cols) if no mesh has any (kernels/texture.py then
    skips it)."""
    if all(v is None for v in per_mesh):
        return np.zeros((0, cols))
    parts = [np.full((n, cols), fill) if v is None else v for v, n in zip(per_mesh, n_vertices)]
    return np.ascontiguousarray(parts[0] if len(parts) == 1 else np.concatenate(parts),
                                dtype=np.float64)


def _textures(materials):
    """(mat_tex, tex_rgb): each material's texture as (offset, width,
    height) into tex_rgb, which holds each image once (kernels/texture.py)."""
    mat_tex = np.zeros((len(materials), 3), np.int64)
    rows, placed = [], {}
    offset = 0
    for m, mat in enumerate(materials):
        image = getattr(mat, "texture", None)
        if image is None:
            continue
        if id(image) not in placed:
            a = np.asarray(image, dtype=np.float32)
            if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
                raise RaytraceError(f"a material's texture must be an (h, w, 3) image, got shape "
                                    f"{a.shape}")
            if not np.isfinite(a).all() or (a < 0).any():
                raise RaytraceError("a material's texture has a negative, NaN or infinite value")
            h, w = a.shape[:2]
            placed[id(image)] = (offset, w, h)
            rows.append(a[:, :, :3].reshape(-1, 3))
            offset += h * w
        mat_tex[m] = placed[id(image)]
    tex_rgb = np.ascontiguousarray(np.concatenate(rows) if rows else np.zeros((0, 3)), np.float32)
    return mat_tex, tex_rgb


@functools.cache
def tiny_geometry():
    """(geometry, object ranges) of eight triangles, a sphere and a plane: a
    scene that loads every builder and traversal a real one uses."""
    from raytrace.scene.model import Mesh, Plane, Sphere
    grid = np.array([(x, y, 0.0) for y in range(3) for x in range(3)], dtype=float)
    quads = [(y * 3 + x, y * 3 + x + 1, y * 3 + x + 4, y * 3 + x + 3)
             for y in range(2) for x in range(2)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    scene = Scene("tiny", Camera((1, 1, 5), (1, 1, 0)),
                  [Mesh(grid, faces), Sphere((1, 1, 1), 0.5), Plane((0, -1, 0), (0, 1, 0))])
    geo, ranges, _ = flatten(scene)
    return geo, ranges
