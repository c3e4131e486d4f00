"""Casting your own rays against meshes or a scene: ``RayScene`` builds the
renderer's buffers and structure once, then answers queries with the batch
kernels (kernels/cast.py) behind validated inputs.

Distances are parametric: a hit is at ``origin + t * direction``, so t is
in units of the direction's length (directions need not be unit length).
Only hits with t_min < t < t_max count.
"""
import numpy as np

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import MAX_COORD, bad_coordinate_rows, check_mesh_arrays
from raytrace.scene.model import Mesh, Scene


class RayHits:
    """Closest hits of n rays.  Each field is an array over the rays,
    reachable as an attribute or by name (``hits.t``, ``hits["t"]``):

    t            (n,) distance along the ray, in units of its direction's length (inf: miss)
    geometry_id  (n,) the mesh hit: the id add_mesh returned, or the index of the object
                 in a Scene's objects (0 for a single mesh); -1: miss
    prim_id      (n,) the face hit, an index into that mesh's faces (0 for a sphere
                 or plane); -1: miss
    u, v         (n,) barycentric weights of the face's second and third vertices:
                 hit point = (1 - u - v) * a + u * b + v * c (NaN: miss, sphere, plane)
    normal       (n, 3) unit geometric normal of the primitive hit: a face's by its
                 winding, (b - a) x (c - a); a sphere's outward; a plane's own (NaN: miss)
    point        (n, 3) the hit point, rebuilt from the primitive (barycentrics on a
                 face, projection onto a sphere or plane), not o + t d (NaN: miss)

    ``object_id`` is another name for ``geometry_id``; ``hit`` is the boolean
    mask of rays that hit; ``stats`` the counters (primitive and box tests)
    under the renderer's names.  normal and point are computed when first
    read, so a caller who wants t alone does not pay for them.
    """
    FIELDS = ("t", "geometry_id", "prim_id", "u", "v", "normal", "point")

    def __init__(self, t, prim, u, v, origins, directions, prepared, stats):
        self.t = t
        self._prim = prim            # the kernel's unified primitive ids
        self._raw_uv = (u, v)
        self._rays = (origins, directions)
        self._prepared = prepared
        self.stats = stats
        self._cache = {}

    def _get(self, name, make):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]

    @property
    def hit(self):
        return self._prim >= 0

    @property
    def geometry_id(self):
        return self._get("geometry_id", lambda: self._prepared.ids(self._prim)[0])

    object_id = geometry_id

    @property
    def prim_id(self):
        return self._get("prim_id", lambda: self._prepared.ids(self._prim)[1])

    def _uv(self):
        tri = self.hit & (self._prim < self._prepared.n_tris)
        return (np.where(tri, self._raw_uv[0], np.nan), np.where(tri, self._raw_uv[1], np.nan))

    @property
    def u(self):
        return self._get("uv", self._uv)[0]

    @property
    def v(self):
        return self._get("uv", self._uv)[1]

    @property
    def normal(self):
        return self._get("surface", self._surface)[0]

    @property
    def point(self):
        return self._get("surface", self._surface)[1]

    def _surface(self):
        return self._prepared.surface(self._prim, *self._raw_uv, self.t, *self._rays)

    def __getitem__(self, name):
        if name not in self.FIELDS and name != "object_id":
            raise KeyError(f"{name!r} (fields: {', '.join(self.FIELDS)})")
        return getattr(self, name)

    def keys(self):
        return self.FIELDS

    def __len__(self):
        return len(self.t)

    def __repr__(self):
        return f"RayHits({len(self)} rays, {int(self.hit.sum())} hits)"


class HitList(RayHits):
    """Every hit along n rays (list_intersections), flat, in Open3D's
    layout: ray i's hits are rows ray_splits[i]:ray_splits[i + 1] of each
    field, nearest first, and ray_id names each row's ray.  The other fields
    are RayHits', over the hits, read the same ways; normal and point are
    computed when first read (on 540,000 hits they cost as much as finding
    the hits)."""
    FIELDS = ("ray_splits", "ray_id") + RayHits.FIELDS

    def __init__(self, splits, t, prim, u, v, origins, directions, prepared, stats):
        super().__init__(t, prim, u, v, origins, directions, prepared, stats)
        self.ray_splits = splits
        self.ray_id = np.repeat(np.arange(len(splits) - 1), np.diff(splits))

    def _surface(self):
        o, d = self._rays
        return self._prepared.surface(self._prim, *self._raw_uv, self.t, o[self.ray_id],
                                      d[self.ray_id])

    def __repr__(self):
        return f"HitList({len(self.ray_splits) - 1} rays, {len(self)} hits)"


class _Prepared:
    """A built scene: kernel buffers, the structure, and the maps from the
    kernel's unified primitive ids back to the user's geometry and faces."""

    def __init__(self, objects, accel):
        from raytrace.accel.registry import build_structure
        from raytrace.scene.flatten import flatten
        scene = Scene(name="rays", camera=None, objects=objects)
        # No shading normals: a ray query reports the geometric normal.
        self.geo, self.obj_ranges, _, (self.prim_object, self.prim_face) = flatten(
            scene, with_sources=True, shading=False)
        self.accel = accel
        self.acc, self.build_s = build_structure(accel, self.geo, self.obj_ranges)
        self.n_tris = self.geo.tri_v0.shape[0]
        self._counting = None
        self._bvh = None
        self._bounds = None

    def bounds(self):
        """(lo, hi) of the bounded primitives (triangles, spheres); None if
        there are none."""
        if self._bounds is None:
            g = self.geo
            lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
            for k in range(3):    # by column: reductions along axis 0 of (n, 3) are slow
                cols = [a[:, k] for a in (g.tri_v0, g.tri_v1, g.tri_v2)]
                cols += [g.sph_center[:, k] - g.sph_radius, g.sph_center[:, k] + g.sph_radius]
                for c in cols:
                    if len(c):
                        lo[k], hi[k] = min(lo[k], c.min()), max(hi[k], c.max())
            self._bounds = (lo, hi) if lo[0] <= hi[0] else ()
        return self._bounds or None

    def counting(self):
        """The layout that counts and lists every hit (made on first use:
        the BVH's holds a copy of the triangles, structures.counting_layout)."""
        if self._counting is None:
            from raytrace.accel.registry import get
            self._counting = get(self.accel).counting_layout(self.acc, self.geo)
        return self._counting

    def bvh(self):
        """The BVH that point queries use, whatever structure casts rays."""
        if self._bvh is None:
            from raytrace.accel.registry import build_structure
            self._bvh = (self.acc if self.accel == "bvh"
                         else build_structure("bvh", self.geo, self.obj_ranges)[0])
        return self._bvh

    def ids(self, prim):
        hit = prim >= 0
        safe = np.where(hit, prim, 0)
        if not len(self.prim_object):
            return np.full(len(prim), -1), np.full(len(prim), -1)
        return (np.where(hit, self.prim_object[safe], -1), np.where(hit, self.prim_face[safe], -1))

    def surface(self, prim, u, v, t, origins, directions):
        """(normal, point) of each hit, NaN rows for misses."""
        g = self.geo
        n = len(prim)
        normal = np.full((n, 3), np.nan)
        point = np.full((n, 3), np.nan)
        n_tris, n_sph = self.n_tris, g.sph_center.shape[0]
        tri = np.flatnonzero((prim >= 0) & (prim < n_tris))
        if len(tri):
            p = prim[tri]
            a, b, c = g.tri_v0[p], g.tri_v1[p], g.tri_v2[p]
            uu, vv = u[tri, None], v[tri, None]
            point[tri] = (1.0 - uu - vv) * a + uu * b + vv * c
            from raytrace.scene.flatten import cross_rows, unit_rows
            normal[tri] = unit_rows(cross_rows(b - a, c - a))
        if n_sph + g.pl_normal.shape[0] == 0:    # triangles only: the usual scene
            return normal, point
        sph = np.flatnonzero((prim >= n_tris) & (prim < n_tris + n_sph))
        if len(sph):
            k = prim[sph] - n_tris
            c, r = g.sph_center[k], g.sph_radius[k, None]
            d = origins[sph] + t[sph, None] * directions[sph] - c
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            normal[sph] = d
            point[sph] = c + r * d
        pl = np.flatnonzero(prim >= n_tris + n_sph)
        if len(pl):
            k = prim[pl] - n_tris - n_sph
            nn, q = g.pl_normal[k], g.pl_point[k]
            x = origins[pl] + t[pl, None] * directions[pl]
            normal[pl] = nn
            point[pl] = x - np.einsum("ij,ij->i", x - q, nn)[:, None] * nn
        return normal, point


def _mesh_arrays(mesh, faces=None):
    """(vertices, faces) from a pair, from two arguments, or from an object
    with .vertices and .faces (a trimesh.Trimesh, a raytrace Mesh)."""
    if faces is not None:
        return mesh, faces
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return mesh.vertices, mesh.faces
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        return mesh
    raise RaytraceError("target must be a (vertices, faces) pair, a mesh with .vertices and "
                        f".faces (such as a trimesh.Trimesh), or a Scene; got {type(mesh).__name__}")


class RayScene:
    """Meshes (or a whole Scene) built once, for any number of ray queries.

        scene = RayScene((vertices, faces))        # or a trimesh.Trimesh, or a Scene
        hits = scene.cast_rays(origins, directions)
        blocked = scene.occluded(origins, directions, t_max=1.0)

    ``RayScene()`` starts empty; ``add_mesh`` adds a mesh and returns its
    geometry id (0, 1, ...).  A Scene's objects (meshes, spheres, planes)
    are geometries numbered by their index in ``scene.objects``.  Inputs are
    validated when added; the structure (``accel``: none, bvol, bvh, grid,
    all giving the same answers) is built at the first query after a change.
    """

    def __init__(self, target=None, accel="bvh"):
        from raytrace.accel.registry import get
        from raytrace.renderer.firstrun import QUERY_S, expect
        get(accel)
        expect(f"ray queries with {accel}", QUERY_S.get(accel))
        self.accel = accel
        self._objects = []
        self._prepared = None
        if isinstance(target, Scene):
            self._objects = list(target.objects)
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

    def _built(self):
        if self._prepared is None:
            self._prepared = _Prepared(self._objects, self.accel)
        return self._prepared

    def cast_rays(self, origins, directions, t_min=0.0, t_max=np.inf):
        """Closest hit of each ray (origins[i], directions[i]) with
        t_min < t < t_max: a RayHits.  origins, directions: (n, 3) (one (3,)
        origin serves every direction, one direction every origin); t_min,
        t_max: numbers or (n,) arrays, 0 <= t_min < t_max (inf allowed)."""
        rays = _rays(origins, directions, t_min, t_max)
        o, d, tmin, tmax = rays
        p = self._built()
        (t, prim, u, v), cnt = _closest(p.geo, p.acc, *rays)
        return RayHits(t, prim, u, v, o, d, p, _counters(cnt, len(d)))

    def occluded(self, origins, directions, t_min=0.0, t_max=np.inf):
        """Whether anything is hit along each ray with t_min < t < t_max: a
        boolean (n,) array.  For a shadow ray, pass the unnormalised
        direction to the light and t_max = 1."""
        p = self._built()
        return _any_hit(p.geo, p.acc, *_rays(origins, directions, t_min, t_max))[0]

    def count_intersections(self, origins, directions, t_min=0.0, t_max=np.inf, max_hits=None):
        """How many times each ray meets the surfaces with t_min < t < t_max:
        an int64 (n,) array.  A ray through a shared edge or vertex of a
        closed mesh crosses it once and is counted once; one grazing an
        edge where the surface folds away is counted 0 or 2 times, so the
        parity of the count still says inside or outside.  max_hits: stop
        counting there (default: no limit).  One traversal per ray, which
        never narrows its interval (the grid scans every primitive: it
        cannot tell a primitive met in two cells from two crossings).  On
        a BVH the first count or listing builds a tree of its own for
        counting and copies the triangles in its leaf order (about 95 bytes
        a triangle, kept with the scene; 11 ms at 20k triangles)."""
        rays = _rays(origins, directions, t_min, t_max)
        p = self._built()
        return np.minimum(_counts(p, rays), _max_hits(max_hits, p))

    def list_intersections(self, origins, directions, t_min=0.0, t_max=np.inf, max_hits=None):
        """Every hit along each ray with t_min < t < t_max, nearest first
        (ties in t: the smaller primitive id first), each crossing counted
        as in count_intersections, at most max_hits per ray (the nearest): a
        HitList, flat arrays in Open3D's layout.  One traversal a ray,
        writing its hits into rows taken as they come (LISTING_GUESS rows a
        ray reserved in all); a second only for rays that find them spent."""
        rays = _rays(origins, directions, t_min, t_max)
        p = self._built()
        limit = _max_hits(max_hits, p)
        splits, (t, prim, u, v), cnt = _listing(p, rays)
        counts = np.diff(splits)
        if counts.max(initial=0) > limit:
            kept = np.minimum(counts, limit)
            ray, j = _rows_of(np.arange(len(counts)), kept)
            rows = splits[ray] + j
            splits, (t, prim, u, v) = _splits(kept), (a[rows] for a in (t, prim, u, v))
        return HitList(splits, t, prim, u, v, *rays[:2], p, _counters(cnt, len(counts)))

    def contains(self, points, votes=1):
        """Whether each point is inside the closed surfaces: a boolean (n,)
        array, by the parity of crossings along a ray from the point out of
        the scene's bounding box the short way (toward the box's nearest
        face, a little off the axis).  One ray is exact on a closed mesh,
        since each crossing counts once even through edges and vertices.
        ``votes=3`` casts three rays, one along each axis toward its nearer
        side, and takes the majority, so a small hole or a stray face cannot
        decide alone (three times the cost).  On an open mesh the answer is
        that parity, meaningful only where the mesh encloses the point; a
        point on the surface may go either way."""
        if votes not in (1, 3):
            raise RaytraceError(f"votes: must be 1 or 3, got {votes!r}")
        q, order = _query_points(points)
        return _unsorted(self._contains(q, votes), order)

    def _contains(self, q, votes):
        odd = np.zeros(len(q), np.int64)
        for d in _exit_directions(q, self._built().bounds(), votes):
            odd += self.count_intersections(q, d) & 1
        return 2 * odd > votes

    def closest_points(self, points):
        """The surfaces' point closest to each query point: a dict of
        ``point`` (n, 3), ``distance``, ``geometry_id`` and ``prim_id`` (as in
        RayHits; -1 for an empty scene) and ``u``, ``v`` (barycentric weights
        of a face's second and third vertex; NaN for spheres and planes).
        Ties between primitives at one distance go to the smaller id.  Point
        queries use a BVH whatever ``accel`` is, so every RayScene answers
        alike."""
        q, order = _query_points(points)
        return {k: _unsorted(a, order) for k, a in self._closest_points(q).items()}

    def _closest_points(self, q):
        p = self._built()
        from raytrace.accel.bvh.points import CHUNK, closest_points
        n = len(q)
        point, prim = np.empty((n, 3)), np.empty(n, np.int64)
        u, v, d2 = np.empty(n), np.empty(n), np.empty(n)
        closest_points(p.geo, p.bvh(), q, point, prim, u, v, d2, _blocks(n, CHUNK), _clock())
        gid, face = p.ids(prim)
        tri = (prim >= 0) & (prim < p.n_tris)
        return {"point": point, "distance": np.sqrt(d2), "geometry_id": gid, "prim_id": face,
                "u": np.where(tri, u, np.nan), "v": np.where(tri, v, np.nan)}

    def distance(self, points):
        """Distance from each point to the nearest surface (inf if none)."""
        q, order = _query_points(points)
        return _unsorted(self._closest_points(q)["distance"], order)

    def signed_distance(self, points):
        """distance(), negative inside the closed surfaces (contains())."""
        q, order = _query_points(points)
        d = self._closest_points(q)["distance"]
        return _unsorted(np.where(self._contains(q, 1), -d, d), order)

    def __repr__(self):
        return f"RayScene({len(self._objects)} geometries, accel={self.accel!r})"


# contains' rays leave the scene's box the short way: a ray crosses fewer
# nodes on a shorter way out (200,000 random points in the box of the peer
# bench's bumpy 20k-triangle sphere, one thread: 145 ms along one fixed
# direction, 30 ms toward the nearest face; the same answers).  Row a
# (axis a, -), row 3 + a (axis a, +): tilted off the axis, with no zero
# and no two equal components, so an axis-aligned mesh's faces and edges
# (or one at 45 degrees) are never met edge-on by construction.
_EXITS = np.array([[-1.0, 0.0311, 0.0457], [0.0123, -1.0, 0.0457], [0.0123, 0.0311, -1.0],
                   [1.0, 0.0311, 0.0457], [0.0123, 1.0, 0.0457], [0.0123, 0.0311, 1.0]])


def _exit_directions(q, bounds, votes):
    """The directions of contains' rays from points q (n, 3): one array
    toward the nearest face of the box ``bounds`` (votes=1), or three,
    along x, y and z toward each axis' nearer side (votes=3)."""
    if bounds is None:     # nothing bounded: any direction does
        return [_EXITS[3 + a] for a in range(votes)]
    lo, hi = bounds
    # Per axis: the distance to the nearer side and whether that is + (a
    # point outside the box has a negative distance on its side: out it goes).
    near = [np.minimum(q[:, a] - lo[a], hi[a] - q[:, a]) for a in range(3)]
    plus = [hi[a] - q[:, a] < q[:, a] - lo[a] for a in range(3)]
    rows = [a + 3 * plus[a] for a in range(3)]
    if votes == 3:
        return [_EXITS[r] for r in rows]
    axis = np.where(near[0] <= near[1], np.where(near[0] <= near[2], 0, 2),
                    np.where(near[1] <= near[2], 1, 2))
    return [_EXITS[np.choose(axis, rows)]]


def _max_hits(max_hits, prepared):
    """A valid bound on hits per ray; None: every primitive twice (a
    sphere's two roots), which no ray can exceed."""
    if max_hits is None:
        g = prepared.geo
        return int(2 * (g.tri_v0.shape[0] + g.sph_center.shape[0] + g.pl_point.shape[0]) + 1)
    if isinstance(max_hits, bool) or not isinstance(max_hits, (int, np.integer)) or max_hits < 1:
        raise RaytraceError(f"max_hits: must be a positive integer or None, got {max_hits!r}")
    return int(max_hits)


def _counts(prepared, rays):
    """How many hits each ray has (cast_counts); RaytraceError if a ray is bad."""
    from raytrace.kernels.cast import cast_counts
    counts = np.empty(len(rays[0]), np.int64)
    cnt = _counter_rows(len(counts))
    cast_counts(prepared.geo, prepared.counting(), *rays, counts, cnt, _clock())
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


def _listing(prepared, rays):
    """(splits, (t, prim, u, v), counters): every hit of each ray, ray i's
    in rows splits[i]:splits[i + 1], in order of (t, primitive id); the
    counters of one traversal a ray."""
    n = len(rays[0])
    block = max(1, LISTING_ROWS // LISTING_GUESS)
    if n <= block:
        return _listing_block(prepared, rays)
    parts = []
    for s in range(0, n, block):
        try:
            parts.append(_listing_block(prepared, [a[s:s + block] for a in rays]))
        except RaytraceError:
            _name_the_problem(*rays)    # the bad ray by its index in the whole call
            raise
    splits = _splits(np.concatenate([np.diff(sp) for sp, _, _ in parts]))
    out = tuple(np.concatenate([o[k] for _, o, _ in parts]) for k in range(4))
    return splits, out, sum(c for _, _, c in parts)


def _run_listing(prepared, rays, rows, start=None):
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
    cast_listing(prepared.geo, prepared.counting(), *rays, start, fixed, slab, *out, found,
                 cnt, np.zeros(2, np.int64))
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


def _listing_block(prepared, rays):
    """_listing for rays whose reserved rows fit in LISTING_ROWS: one
    traversal into LISTING_GUESS rows a ray, taken in slabs, the written
    rays' rows packed into place, the others traversed again."""
    n = len(rays[0])
    start, found, first, cnt = _run_listing(prepared, rays, n * LISTING_GUESS)
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
        _, found_again, rows, _ = _run_listing(prepared, sub, int(sub_splits[-1]), sub_splits)
        if not np.array_equal(found_again, found[again]):   # the same tests, both times
            raise RuntimeError("list_intersections: the second pass found other hits than "
                               "the first (a bug: please report it)")
        ray, j = _rows_of(again, found[again])
        dst = splits[ray] + j
        for o, r in zip(out, rows):
            o[dst] = r
    return splits, out, cnt


def _as_rows(name, a):
    """(n, 3) float64 array, or (3,) as one row; values are checked later."""
    try:
        raw = np.asarray(a)
        if np.iscomplexobj(raw):
            raise RaytraceError(f"{name}: complex numbers are not coordinates")
        arr = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:   # ragged rows, text
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if arr.ndim == 1 and arr.shape[0] == 3:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise RaytraceError(f"{name}: expected shape (n, 3), got {arr.shape}")
    return kernel_array(arr)


def _interval_end(name, value, n):
    """An (n,) float64 array from a number or an (n,) array-like."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RaytraceError(f"{name}: not convertible to float64 ({exc})") from None
    if a.ndim == 0:
        return _filled(n, float(a))
    if a.shape != (n,):
        raise RaytraceError(f"{name}: expected a number or shape ({n},), got shape {a.shape}")
    return kernel_array(a)


# Bounds given as numbers, filled out for the kernels and kept for the next
# call with the same size: a fresh (n,) array faults its pages in on first
# write (~0.4 ms a MB here), 0.5 ms of a 13 ms call of 307,200 rays at 118k
# triangles.  The kernels only read them, and they are never handed out.
_FILLED = {}
_FILLED_MAX = 4                  # arrays kept
_FILLED_MAX_BYTES = 8 << 20      # each


def _filled(n, value):
    key = (n, value.hex())    # by bits: -0.0 is not 0.0, and NaN is NaN
    a = _FILLED.get(key)
    if a is None:
        a = np.full(n, value)
        if a.nbytes <= _FILLED_MAX_BYTES:
            if len(_FILLED) >= _FILLED_MAX:
                _FILLED.clear()
            _FILLED[key] = a
    return a


def _rays(origins, directions, t_min, t_max):
    """Validated kernel arrays (origins, directions, t_min, t_max)."""
    o = _as_rows("origins", origins)
    d = _as_rows("directions", directions)
    if len(o) == 1 and len(d) > 1:     # one origin for every direction
        o = np.ascontiguousarray(np.broadcast_to(o, d.shape))
    if len(d) == 1 and len(o) > 1:     # one direction for every origin
        d = np.ascontiguousarray(np.broadcast_to(d, o.shape))
    if len(o) != len(d):
        raise RaytraceError(f"origins and directions differ in length ({len(o)} and {len(d)})")
    n = len(d)
    tmin = _interval_end("t_min", t_min, n)
    tmax = _interval_end("t_max", t_max, n)
    return o, d, tmin, tmax


def _check_rays(cnt, rays):
    """After a query kernel: raise RaytraceError naming the first bad ray
    if the kernel found any (kernels/cast.py checks each ray as it reads
    it, instead of a pass of its own before the call)."""
    from raytrace.kernels.counters import BAD_RAYS
    if cnt[..., BAD_RAYS].any():
        _name_the_problem(*rays)


# Point queries run in Morton order of a 32^3 grid over the points' bounds
# (a 15-bit key: NumPy's stable argsort of 16-bit keys is a radix sort), so
# neighbouring queries visit the same BVH nodes while they are in cache.
# 200,000 random points in a 20k-triangle sphere's box: distance 273 -> 154
# ms, contains 208 -> 155 ms, signed_distance 476 -> 302 ms, with the 3-5 ms
# of ordering.  Smaller batches gain too little to pay for it.
_ORDER_MIN = 20_000
_MORTON_BITS = 5
_SPREAD = np.array([sum(((v >> b) & 1) << (3 * b) for b in range(_MORTON_BITS))
                    for v in range(1 << _MORTON_BITS)], np.uint16)


def _query_points(points):
    """(validated (n, 3) points in the order the kernels take them, the
    permutation that made that order or None)."""
    q = _as_rows("points", points)
    _check_coordinates("points", q)
    if len(q) < _ORDER_MIN:
        return q, None
    # Column by column: NumPy's reductions along axis 0 of an (n, 3) array
    # are ~10x slower.
    lo = np.array([q[:, a].min() for a in range(3)])
    hi = np.array([q[:, a].max() for a in range(3)])
    # (q - lo) / span is in [0, 1] for any span > 0, subnormal too (a scale
    # factor 31 / span would overflow there); a flat axis gets span 1.
    span = np.where(hi > lo, hi - lo, 1.0)
    cell = ((q - lo) / span * ((1 << _MORTON_BITS) - 1)).astype(np.intp)
    key = _SPREAD[cell[:, 0]] | (_SPREAD[cell[:, 1]] << 1) | (_SPREAD[cell[:, 2]] << 2)
    order = np.argsort(key, kind="stable")
    return np.take(q, order, axis=0), order


def _unsorted(a, order):
    """Results for points in _query_points' order, back in the caller's."""
    if order is None:
        return a
    out = np.empty_like(a)
    out[order] = a
    return out


def _check_coordinates(name, arr):
    """Raise RaytraceError naming the first row of NaN, inf or too large values."""
    bad = bad_coordinate_rows(arr)
    if bad is not None and bad[0] == "nonfinite":
        raise RaytraceError(f"{name}[{bad[1]}]: NaN or infinite value ({bad[2]} such rows)")
    if bad is not None:
        raise RaytraceError(f"{name}[{bad[1]}]: a value beyond {MAX_COORD:g} "
                            f"(products of such values overflow; {bad[2]} such rows)")


def _name_the_problem(o, d, tmin, tmax):
    """Raise RaytraceError naming the first bad ray and how many share it."""
    _check_coordinates("origins", o)
    _check_coordinates("directions", d)
    zero = (d[:, 0] == 0.0) & (d[:, 1] == 0.0) & (d[:, 2] == 0.0)
    if zero.any():
        raise RaytraceError(f"directions[{int(np.argmax(zero))}]: zero vector (a ray needs a direction)")
    bad = ~(tmax > 0)   # also catches NaN
    if bad.any():
        raise RaytraceError(f"t_max[{int(np.argmax(bad))}]: must be positive (inf allowed), "
                            f"got {tmax[np.argmax(bad)]}")
    bad = ~((tmin >= 0) & (tmin < tmax))
    k = int(np.argmax(bad))
    raise RaytraceError(f"t_min[{k}]: must be finite, at least 0 and below t_max "
                        f"({tmax[k]}), got {tmin[k]}")


def kernel_array(a, dtype=np.float64):
    """``a`` as a C-contiguous, aligned, writeable array of ``dtype`` (a copy
    only when it is not one already): a read-only or strided array would
    compile the kernels again for its type."""
    a = np.asarray(a)
    if a.dtype != dtype or not (a.flags.c_contiguous and a.flags.aligned and a.flags.writeable):
        a = np.array(a, dtype=dtype, order="C", copy=True)
    return a


def _blocks(n, chunk=None):
    """Counter rows: one per thread (kernels/cast.py: each takes chunks of
    rays, or of points, by ticket), fewer when there are fewer chunks than
    threads.  One block runs in the calling thread, without waking Numba's."""
    import numba

    from raytrace.kernels.cast import CHUNK
    return max(1, min(numba.get_num_threads(), -(-n // (chunk or CHUNK))))


def _counter_rows(n):
    """Zeroed counter rows for a query kernel over n rays (kernels/cast.py)."""
    from raytrace.kernels.cast import COLUMNS
    return np.zeros((_blocks(n), COLUMNS), np.int64)


def _clock():
    """A query kernel's chunk clock (kernels/cast.py): the first ticket is 0."""
    return np.zeros(1, np.int64)


def _closest(geo, acc, origins, dirs, t_min, t_max):
    """((t, prim, b1, b2), counters) for (n, 3) rays and (n,) bounds;
    RaytraceError if a ray is bad."""
    from raytrace.kernels.cast import cast_closest
    n = len(origins)
    out = (np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n))
    cnt = _counter_rows(n)
    cast_closest(geo, acc, origins, dirs, t_min, t_max, *out, cnt, _clock())
    _check_rays(cnt, (origins, dirs, t_min, t_max))
    return out, cnt.sum(axis=0)


def _any_hit(geo, acc, origins, dirs, t_min, t_max):
    """(occluded bool array, counters); RaytraceError if a ray is bad."""
    from raytrace.kernels.cast import cast_occluded
    n = len(origins)
    hit = np.empty(n, np.bool_)
    cnt = _counter_rows(n)
    cast_occluded(geo, acc, origins, dirs, t_min, t_max, hit, cnt, _clock())
    _check_rays(cnt, (origins, dirs, t_min, t_max))
    return hit, cnt.sum(axis=0)


def _counters(cnt, n):
    from raytrace.renderer.stats import counters_from_rows
    c = counters_from_rows(cnt[None, :])
    return {"rays": n, "prim_tests": c["prim_tests"], "prim_hits": c["prim_hits"],
            "box_tests": c["box_tests"], "nodes_visited": c["nodes_visited"],
            "cells_visited": c["cells_visited"]}


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
                            ".faces (such as a trimesh.Trimesh), or a Scene; got None")
    return RayScene(target, accel)


def create_rays_pinhole(fov, center, eye, up, width, height):
    """Rays of a pinhole camera at ``eye`` looking at ``center``, Open3D's
    convention: ``fov`` is the horizontal field of view in degrees, the
    principal point the image centre, one ray through each pixel centre
    (x + 0.5, y + 0.5), directions not normalised (unit depth along the
    view axis, so t is depth).  Returns an (height, width, 6) float64 array
    of (origin, direction) rows; ``rays[..., :3]`` and ``rays[..., 3:]``
    go straight into ``cast_rays``.  As in Open3D, the camera's x axis is
    up x forward and its y axis ``up``, so row 0 looks along -up and column
    0 along +(forward x up): the picture is half a turn from a photograph's
    (``image[::-1, ::-1]`` shows it upright)."""
    width, height = _pixels(width, height)
    fov = _number("fov", fov)
    if not 0.0 < fov < 180.0:
        raise RaytraceError(f"fov: must be between 0 and 180 degrees, got {fov}")
    eye, center, up = (_vector(n, x) for n, x in (("eye", eye), ("center", center), ("up", up)))
    fwd = center - eye
    if not np.linalg.norm(fwd) > 0:
        raise RaytraceError("center: must differ from eye")
    fwd /= np.linalg.norm(fwd)
    right = np.cross(up, fwd)
    if not np.linalg.norm(right) > 1e-12 * np.linalg.norm(up):
        raise RaytraceError("up: must not be parallel to the view direction (center - eye)")
    right /= np.linalg.norm(right)
    true_up = np.cross(fwd, right)
    focal = 0.5 * width / np.tan(np.radians(fov) / 2.0)
    intrinsic = np.array([[focal, 0.0, 0.5 * width], [0.0, focal, 0.5 * height], [0.0, 0.0, 1.0]])
    rotation = np.stack([right, true_up, fwd])         # world -> camera
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation
    extrinsic[:3, 3] = -rotation @ eye
    return create_rays_from_matrices(intrinsic, extrinsic, width, height)


def create_rays_from_matrices(intrinsic, extrinsic, width, height):
    """Rays of a pinhole camera given as a 3x3 intrinsic matrix K and a 4x4
    world-to-camera extrinsic matrix [R | t] (Open3D's and OpenCV's
    convention): the ray through pixel centre (x + 0.5, y + 0.5) starts at
    the camera centre -R^T t with direction R^T K^-1 (x + 0.5, y + 0.5, 1).
    Returns an (height, width, 6) float64 array."""
    width, height = _pixels(width, height)
    k = _matrix("intrinsic", intrinsic, (3, 3))
    e = _matrix("extrinsic", extrinsic, (4, 4))
    try:
        k_inv = np.linalg.inv(k)
    except np.linalg.LinAlgError:
        raise RaytraceError("intrinsic: the matrix is singular") from None
    r, t = e[:3, :3], e[:3, 3]
    ys, xs = np.mgrid[0:height, 0:width]
    pix = np.stack([xs + 0.5, ys + 0.5, np.ones_like(xs, dtype=float)], axis=-1)
    rays = np.empty((height, width, 6))
    rays[..., :3] = -r.T @ t
    rays[..., 3:] = pix @ (r.T @ k_inv).T
    return rays


def _pixels(width, height):
    out = []
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 1 << 16:
            raise RaytraceError(f"{name}: must be an integer from 1 to 65536, got {v!r}")
        out.append(int(v))
    return out


def _number(name, v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise RaytraceError(f"{name}: must be a number, got {v!r}") from None
    if not np.isfinite(x):
        raise RaytraceError(f"{name}: must be finite, got {x}")
    return x


def _vector(name, v):
    a = _matrix(name, v, (3,))
    if not np.abs(a).max() <= MAX_COORD:
        raise RaytraceError(f"{name}: a value beyond {MAX_COORD:g}")
    return a


def _matrix(name, v, shape):
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise RaytraceError(f"{name}: must be numbers of shape {shape}") from None
    if a.shape != shape:
        raise RaytraceError(f"{name}: expected shape {shape}, got {a.shape}")
    if not np.isfinite(a).all():
        raise RaytraceError(f"{name}: NaN or infinite value")
    return a
