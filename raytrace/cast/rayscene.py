"""Casting your own rays against meshes or a scene: ``RayScene`` builds the
renderer's buffers and structure once, then answers queries with the batch
kernels (kernels/cast.py) behind validated inputs (rays.py); the answers
are results.py's, the camera rays cameras.py's.

Distances are parametric: a hit is at ``origin + t * direction``, so t is
in units of the direction's length (directions need not be unit length).
Only hits with t_min < t < t_max count; a negative t_min counts hits at
the origin itself (t = 0) too, never behind it.
"""
import numpy as np

from raytrace.cast.prepared import _mesh_arrays, _Prepared, _trimesh_scene_meshes
from raytrace.cast.rays import (
    _any_hit,
    _blocks,
    _check_rays,
    _clock,
    _closest,
    _counter_rows,
    _counters,
    _name_the_problem,
    _query_points,
    _rays,
    _shaped,
    _unsorted,
    fresh_columns,
    in_order,
)
from raytrace.cast.results import ClosestPoints, HitList, RayHits
from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import check_mesh_arrays
from raytrace.scene.model import Mesh, Scene


class RayScene:
    """Meshes (or a whole Scene) built once, for any number of ray queries.

        scene = RayScene((vertices, faces))        # or a trimesh.Trimesh or Scene, or a Scene
        hits = scene.cast_rays(origins, directions)
        blocked = scene.occluded(origins, directions, t_max=1.0)

    ``RayScene()`` starts empty; ``add_mesh`` adds a mesh and returns its
    geometry id (0, 1, ...).  A Scene's objects (meshes, spheres, planes)
    are geometries numbered by their index in ``scene.objects``; a
    trimesh.Scene's meshes, each where its node places it, in the order of
    ``scene.graph.nodes_geometry``.  Inputs are
    validated when added; the structure (``accel``: a name in
    raytrace.accel.registry.STRUCTURES, all giving the same answers) is
    built at the first query after a change.
    """

    def __init__(self, target=None, accel="bvh"):
        from raytrace.accel.registry import get
        from raytrace.renderer.firstrun import QUERY_S, expect
        get(accel)
        expect(f"ray queries with {accel}", QUERY_S.get(accel))
        self.accel = accel
        self._objects = []
        self._prepared = None
        # Whether a bad ray (NaN, zero direction, t_min >= t_max) raises;
        # the Open3D drop-in (open3d_scene.py) answers it as a miss instead.
        self._check = True
        placed = _trimesh_scene_meshes(target)
        if isinstance(target, Scene):
            self._objects = list(target.objects)
        elif placed is not None:
            for vertices, faces, node in placed:
                self._add(vertices, faces, name=f"target node {node!r}")
        elif target is not None:
            self._add(*_mesh_arrays(target), name="target")

    def add_mesh(self, mesh, faces=None):
        """Add a mesh: ``add_mesh((vertices, faces))``, ``add_mesh(vertices,
        faces)`` or ``add_mesh(trimesh_mesh)``.  Returns its geometry id."""
        return self._add(*_mesh_arrays(mesh, faces), name=f"mesh {len(self._objects)}")

    def _add(self, vertices, faces, name):
        v, f = check_mesh_arrays(name, vertices, faces)
        self._objects.append(Mesh(v, f, name=name))
        self._prepared = None
        return len(self._objects) - 1

    def _built(self, query=None, n_rays=0, wait=True):
        """The prepared scene, built at the first query after a change.
        For a first query (``query``, of ``n_rays`` rays: one of
        cast/ahead.py's names), the query's kernel and the structure's
        builder compile in two processes at once (cast/ahead.py); what the
        second one compiled is adopted before the call (with ``wait``,
        before this returns; else at the query's next call)."""
        if query is None:
            if self._prepared is None:
                self._prepared = _Prepared(self._objects, self.accel)
            return self._prepared
        from raytrace.cast import ahead
        if self._prepared is None:
            from raytrace.renderer.firstrun import expect, query_seconds
            expect(f"ray queries with {self.accel}", query_seconds(self.accel, query, n_rays))
            ahead.start(self.accel, query, n_rays)
            try:
                ahead.before_build()
                self._prepared = _Prepared(self._objects, self.accel)
            except BaseException:
                ahead.cancel()
                raise
        if wait:
            ahead.wait(query)
        return self._prepared

    def cast_rays(self, origins, directions=None, t_min=0.0, t_max=np.inf):
        """Closest hit of each ray (origins[i], directions[i]) with
        t_min < t < t_max: a RayHits.  origins, directions: (n, 3) (one (3,)
        origin serves every direction, one direction every origin), or of
        any shape (..., 3), answered in that shape; or one (..., 6) array
        of (origin, direction) rows, as create_rays_pinhole and Open3D make
        them.  t_min, t_max: numbers or arrays over the rays, t_min < t_max
        (inf allowed); t_min < 0 counts hits at the origin (t = 0) too."""
        rays, shape, given = _rays(origins, directions, t_min, t_max)
        p = self._built("closest", len(rays[0]))
        (t, prim, u, v), cnt = _closest(p.scene("rays"), *rays, self._check, p.entries)
        return RayHits(t, prim, u, v, *given, p, _counters(cnt, len(t)), shape)

    def occluded(self, origins, directions=None, t_min=0.0, t_max=np.inf):
        """Whether anything is hit along each ray with t_min < t < t_max: a
        boolean array over the rays (rays as cast_rays takes them).  For a
        shadow ray, pass the unnormalised direction to the light and t_max = 1."""
        rays, shape, _ = _rays(origins, directions, t_min, t_max)
        p = self._built("occluded", len(rays[0]))
        return _shaped(_any_hit(p.scene("rays"), *rays, self._check, p.entries)[0], shape)

    def count_intersections(self, origins, directions=None, t_min=0.0, t_max=np.inf,
                            max_hits=None):
        """How many times each ray meets the surfaces with t_min < t < t_max:
        an int64 array over the rays (rays as cast_rays takes them).  A ray
        through a shared edge or vertex of a
        closed mesh crosses it once and is counted once; one grazing an
        edge where the surface folds away is counted 0 or 2 times, so the
        parity of the count still says inside or outside.  max_hits: stop
        counting there (default: no limit).  One traversal per ray, which
        never narrows its interval (the grid scans every primitive: it
        cannot tell a primitive met in two cells from two crossings).  On
        a BVH the first count or listing builds a tree of its own for
        counting and copies the triangles in its leaf order (about 95 bytes
        a triangle, kept with the scene)."""
        rays, shape, _ = _rays(origins, directions, t_min, t_max)
        p = self._built("count", len(rays[0]))
        return _shaped(np.minimum(_counts(p, rays, self._check), _max_hits(max_hits, p)), shape)

    def list_intersections(self, origins, directions=None, t_min=0.0, t_max=np.inf,
                           max_hits=None):
        """Every hit along each ray with t_min < t < t_max, nearest first
        (ties in t: the smaller primitive id first), each crossing counted
        as in count_intersections, at most max_hits per ray (the nearest): a
        HitList, flat arrays in Open3D's layout over the rays in row-major
        order (rays as cast_rays takes them).  One traversal a ray,
        writing its hits into rows taken as they come (LISTING_GUESS rows a
        ray reserved in all); a second only for rays that find them spent."""
        rays, _, given = _rays(origins, directions, t_min, t_max)
        p = self._built("list", len(rays[0]))
        limit = _max_hits(max_hits, p)
        splits, (t, prim, u, v), cnt = _listing(p, rays, self._check)
        counts = np.diff(splits)
        if counts.max(initial=0) > limit:
            kept = np.minimum(counts, limit)
            ray, j = _rows_of(np.arange(len(counts)), kept)
            rows = splits[ray] + j
            splits, (t, prim, u, v) = _splits(kept), (a[rows] for a in (t, prim, u, v))
        return HitList(splits, t, prim, u, v, *given, p, _counters(cnt, len(counts)))

    def contains(self, points, votes=1):
        """Whether each point is inside the closed surfaces: a boolean (n,)
        array, by the parity of crossings along a ray from the point out of
        the scene's bounding box the short way (toward the box's nearest
        face, a little off the axis).  One ray is exact on a closed mesh,
        since each crossing counts once even through edges and vertices.
        ``votes`` (odd) casts that many rays and takes the majority, so a
        small hole or a stray face cannot decide alone (votes times the
        cost): 3 go along each axis toward its nearer side, 5 and 6 add the
        farther sides, more add directions spread over the sphere.  On an
        open mesh the answer is that parity, meaningful only where the mesh
        encloses the point; a point on the surface may go either way."""
        votes = _votes(votes)
        q, order = _query_points(points)
        return _unsorted(self._contains(q, votes), order)

    def _contains(self, q, votes):
        odd = np.zeros(len(q), np.int64)
        for d in _exit_directions(q, self._built("count", len(q) * votes).bounds(), votes):
            odd += self.count_intersections(q, d) & 1
        return 2 * odd > votes

    def closest_points(self, points):
        """The surfaces' point closest to each query point: a ClosestPoints,
        fields ``point`` (n, 3), ``distance``, ``geometry_id``, ``prim_id``,
        ``u``, ``v`` and ``normal``, read as RayHits' are.  Ties between
        primitives at one distance go to the smaller id.  Point queries use
        a BVH whatever ``accel`` is, so every RayScene answers alike."""
        q, order = _query_points(points)
        return ClosestPoints(*self._closest_points(q), self._built("points"), order)

    def _closest_points(self, q, order=None):
        p = self._built("points", len(q))
        from raytrace.accel.bvh.points import CHUNK, closest_points
        n = len(q)
        point, prim, u, v, d2 = fresh_columns(n, ((np.float64, 3), (np.int64, 1), (np.float64, 1),
                                                  (np.float64, 1), (np.float64, 1)))
        closest_points(p.scene("points"), q, point, prim, u, v, d2, _blocks(n, CHUNK), _clock(),
                       p.entries)
        return point, d2, prim, u, v

    def distance(self, points):
        """Distance from each point to the nearest surface (inf if none)."""
        q, order = _query_points(points)
        return _unsorted(np.sqrt(self._closest_points(q)[1]), order)

    def signed_distance(self, points, votes=1):
        """distance(), negative inside the closed surfaces (contains(),
        with its ``votes``)."""
        votes = _votes(votes)
        q, order = _query_points(points)
        # A first call: the count's compiles split first (cast/ahead.py),
        # the longer ones; where its kernel goes to the second process,
        # the point query's compiles here meanwhile.
        self._built("count", len(q) * votes, wait=False)
        d = np.sqrt(self._closest_points(q)[1])
        return _unsorted(np.where(self._contains(q, votes), -d, d), order)

    def __repr__(self):
        return f"RayScene({len(self._objects)} geometries, accel={self.accel!r})"


# contains' rays leave the scene's box the short way: a ray crosses fewer
# nodes on a shorter way out (docs/benchmarks.md, "Ray queries").  Row a
# (axis a, -), row 3 + a (axis a, +): tilted off the axis, with no zero
# and no two equal components, so an axis-aligned mesh's faces and edges
# (or one at 45 degrees) are never met edge-on by construction.
_EXITS = np.array([[-1.0, 0.0311, 0.0457], [0.0123, -1.0, 0.0457], [0.0123, 0.0311, -1.0],
                   [1.0, 0.0311, 0.0457], [0.0123, 1.0, 0.0457], [0.0123, 0.0311, 1.0]])


def _votes(votes):
    if isinstance(votes, bool) or not isinstance(votes, (int, np.integer)) or votes < 1 \
            or votes % 2 == 0:
        raise RaytraceError(f"votes: must be an odd positive integer, got {votes!r}")
    return int(votes)


def _spread_directions(k):
    """k unit directions spread over the sphere (a golden-angle spiral),
    each turned off the axes like _EXITS' rows."""
    i = np.arange(k) + 0.5
    z = 1.0 - 2.0 * i / k
    phi = i * np.pi * (3.0 - np.sqrt(5.0)) + 0.0457
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _exit_directions(q, bounds, votes):
    """The directions of contains' rays from points q (n, 3): one array
    toward the nearest face of the box ``bounds`` (votes=1); along x, y
    and z toward each axis' nearer side (votes=3); then toward the farther
    sides (up to 6), then fixed directions spread over the sphere."""
    if bounds is None:     # nothing bounded: any direction does
        near_rows, far_rows = list(_EXITS[3:]), list(_EXITS[:3])
        if votes == 1:
            return near_rows[:1]
    else:
        lo, hi = bounds
        # Per axis (columns): the distance to the nearer side and whether
        # that is + (a point outside the box has a negative distance on its
        # side: out it goes).  Whole arrays, not a column at a time: a
        # call of one point is mostly NumPy's per-call cost.
        below, above = q - lo, hi - q
        rows = _AXES + 3 * (above < below)
        if votes == 1:
            n0, n1, n2 = np.minimum(below, above).T
            axis = np.where(n0 <= n1, np.where(n0 <= n2, 0, 2), np.where(n1 <= n2, 1, 2))
            return [_EXITS[rows[np.arange(len(q)), axis]]]
        near_rows = [_EXITS[rows[:, a]] for a in range(3)]
        far_rows = [_EXITS[(rows[:, a] + 3) % 6] for a in range(3)]
    if votes >= 3:
        out = (near_rows + far_rows)[:votes]
        return out + list(_spread_directions(votes - len(out))) if votes > 6 else out


_AXES = np.arange(3)


def _max_hits(max_hits, prepared):
    """A valid bound on hits per ray; None: every primitive twice (a
    sphere's two roots), which no ray can exceed."""
    if max_hits is None:
        g = prepared.geo
        return int(2 * (g.tri_v0.shape[0] + g.sph_center.shape[0] + g.pl_point.shape[0]) + 1)
    if isinstance(max_hits, bool) or not isinstance(max_hits, (int, np.integer)) or max_hits < 1:
        raise RaytraceError(f"max_hits: must be a positive integer or None, got {max_hits!r}")
    return min(int(max_hits), _max_hits(None, prepared))    # more than any ray can have: no limit


def _counts(prepared, rays, check=True):
    """How many hits each ray has (cast_counts); RaytraceError if a ray is
    bad (with ``check``; else its count is 0)."""
    from raytrace.kernels.cast import cast_counts
    counts = np.empty(len(rays[0]), np.int64)
    scene, entries = prepared.scene("counting"), prepared.entries
    cnt = in_order(scene, rays, (counts,), lambda window, answers, row:
                   cast_counts(scene, *window, *answers, row, _clock(), entries))
    if cnt is None:
        cnt = _counter_rows(len(counts))
        cast_counts(scene, *rays, counts, cnt, _clock(), entries)
    if check:
        _check_rays(cnt, rays)
    return counts


# list_intersections writes each ray's hits in the traversal that counts
# them, into rows its thread takes in slabs as hits come (kernels/cast.py),
# LISTING_GUESS rows a ray in all; only rays whose hits find the rows spent
# are traversed again, into rows their counts size.  Random rays through a
# closed mesh meet it 0-4 times.  At most LISTING_ROWS rows (32 bytes each)
# are reserved at once: more rays than that go in blocks.
LISTING_GUESS = 4


LISTING_ROWS = 1 << 22


def _listing(prepared, rays, check=True):
    """(splits, (t, prim, u, v), counters): every hit of each ray, ray i's
    in rows splits[i]:splits[i + 1], in order of (t, primitive id); the
    counters of one traversal a ray."""
    n = len(rays[0])
    block = max(1, LISTING_ROWS // LISTING_GUESS)
    if n <= block:
        return _listing_block(prepared, rays, check)
    parts = []
    for s in range(0, n, block):
        try:
            parts.append(_listing_block(prepared, [a[s:s + block] for a in rays], check))
        except RaytraceError:
            _name_the_problem(*rays)    # the bad ray by its index in the whole call
            raise
    splits = _splits(np.concatenate([np.diff(sp) for sp, _, _ in parts]))
    out = tuple(np.concatenate([o[k] for _, o, _ in parts]) for k in range(4))
    return splits, out, sum(c for _, _, c in parts)


def _run_listing(prepared, rays, rows, start=None, check=True):
    """cast_listing into ``rows`` fresh rows: (start, found, rows, counters).
    With ``start`` (splits), each ray's rows are given; without, taken in
    slabs, and start[i] is -1 for a ray not written (rows spent)."""
    from raytrace.kernels.cast import SLAB, cast_listing
    n = len(rays[0])
    out = (np.empty(rows), np.empty(rows, np.int64), np.empty(rows), np.empty(rows))
    found = np.empty(n, np.int64)
    fixed = start is not None
    if not fixed:
        start = np.empty(n + 1, np.int64)
    cnt = _counter_rows(n)
    # Slabs of at most a quarter of a thread's share, so that no thread's
    # first slab leaves the others without rows.
    slab = max(1, min(SLAB, rows // (4 * len(cnt))))
    cast_listing(prepared.scene("counting"), tuple(rays), start, fixed, slab, out, found,
                 cnt, np.zeros(2, np.int64), prepared.entries)
    if check:
        _check_rays(cnt, rays)
    return start[:n], found, out, cnt.sum(axis=0)


def _splits(counts):
    """Each ray's first row, and the end, of rows laid out ray after ray:
    (n + 1,) int64, from the rays' row counts."""
    splits = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts, out=splits[1:])
    return splits


def _rows_of(rays, counts):
    """(ray, j) of the rows j < counts[r] of each ray r of ``rays`` in turn:
    the rays repeated, and each row's place among its ray's."""
    ends = np.cumsum(counts)
    ray = np.repeat(rays, counts)
    return ray, np.arange(len(ray)) - np.repeat(ends - counts, counts)


def _listing_block(prepared, rays, check=True):
    """_listing for rays whose reserved rows fit in LISTING_ROWS: one
    traversal into LISTING_GUESS rows a ray, taken in slabs, the written
    rays' rows packed into place, the others traversed again."""
    n = len(rays[0])
    start, found, first, cnt = _run_listing(prepared, rays, n * LISTING_GUESS, None, check)
    splits = _splits(found)
    out = tuple(np.empty(int(splits[-1]), a.dtype) for a in first)
    written = start >= 0
    ray, j = _rows_of(np.flatnonzero(written), found[written])
    src, dst = start[ray] + j, splits[ray] + j
    for o, f in zip(out, first):
        o[dst] = f[src]
    again = np.flatnonzero(~written)
    if len(again):
        sub = [np.ascontiguousarray(a[again]) for a in rays]
        sub_splits = _splits(found[again])
        _, found_again, rows, _ = _run_listing(prepared, sub, int(sub_splits[-1]), sub_splits,
                                               check)
        if not np.array_equal(found_again, found[again]):   # the same tests, both times
            raise RuntimeError("list_intersections: the second pass found other hits than "
                               "the first (a bug: please report it)")
        ray, j = _rows_of(again, found[again])
        dst = splits[ray] + j
        for o, r in zip(out, rows):
            o[dst] = r
    return splits, out, cnt


def cast_rays(target, origins, directions, accel="bvh", t_max=None):
    """Closest hit of each ray against ``target`` (a (vertices, faces) pair,
    a mesh with .vertices and .faces, or a Scene), built for this call
    alone: ``RayScene(target, accel).cast_rays(...)``.  Build a RayScene to
    cast many batches against the same target."""
    scene = _scene_for(target, accel)
    return scene.cast_rays(origins, directions, t_max=np.inf if t_max is None else t_max)


def occluded(target, origins, directions, t_max, accel="bvh"):
    """Whether anything blocks each ray with 0 < t < t_max (required: inf
    for anywhere along the ray): ``RayScene(target, accel).occluded(...)``."""
    if t_max is None:
        raise RaytraceError("t_max: required (the distance up to which a ray is blocked)")
    return _scene_for(target, accel).occluded(origins, directions, t_max=t_max)


def _scene_for(target, accel):
    if target is None:
        raise RaytraceError("target must be a (vertices, faces) pair, a mesh with .vertices and "
                            ".faces (such as a trimesh.Trimesh), a trimesh.Scene or a raytrace "
                            "Scene; got None")
    return RayScene(target, accel)
