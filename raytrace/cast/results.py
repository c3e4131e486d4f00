"""Query answers: ``RayHits`` (the closest hits, fields computed on first
read), ``HitList`` (every hit, Open3D's flat layout) and ``ClosestPoints``."""
import numpy as np

from raytrace.cast.rays import _unsorted


class _Fields:
    """A query's answer: named arrays read as attributes or, as from a
    dict, by name (``r.t``, ``r["t"]``, ``r.keys()``, ``r.items()``)."""
    FIELDS = ()
    ALIASES = ()

    def __getitem__(self, name):
        if name not in self.FIELDS and name not in self.ALIASES:
            raise KeyError(f"{name!r} (fields: {', '.join(self.FIELDS)})")
        return getattr(self, name)

    def keys(self):
        return self.FIELDS

    def __iter__(self):
        return iter(self.FIELDS)

    def items(self):
        return [(k, getattr(self, k)) for k in self.FIELDS]

    def values(self):
        return [getattr(self, k) for k in self.FIELDS]


class RayHits(_Fields):
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
    read, so a caller who wants t alone does not pay for them.  Rays given
    in a shape such as (h, w, 6) answer in that shape: t is (h, w), normal
    (h, w, 3).
    """
    FIELDS = ("t", "geometry_id", "prim_id", "u", "v", "normal", "point")
    ALIASES = ("object_id",)

    def __init__(self, t, prim, u, v, origins, directions, prepared, stats, shape=None):
        self._shape = shape          # the rays' leading shape, None for (n,) rows
        self.t = self._shaped(t)
        self._prim = prim            # the kernel's unified primitive ids
        self._raw_uv = (u, v)
        self._rays = (origins, directions)
        self._prepared = prepared
        self._stats = stats          # a dict, or a function making it when first read
        self._cache = {}

    def _shaped(self, a):
        return a if self._shape is None else a.reshape(self._shape + a.shape[1:])

    def _get(self, name, make):
        if name not in self._cache:
            made = make()
            self._cache[name] = (tuple(self._shaped(a) for a in made) if isinstance(made, tuple)
                                 else self._shaped(made))
        return self._cache[name]

    @property
    def stats(self):
        if callable(self._stats):
            self._stats = self._stats()
        return self._stats

    @property
    def hit(self):
        return self._shaped(self._prim >= 0)

    @property
    def geometry_id(self):
        return self._get("geometry_id", lambda: self._prepared.geometry_ids(self._prim))

    object_id = geometry_id

    @property
    def prim_id(self):
        return self._get("prim_id", lambda: self._prepared.faces(self._prim))

    def _uv(self):
        tri = (self._prim >= 0) & (self._prim < self._prepared.n_tris)
        return (np.where(tri, self._raw_uv[0], np.nan), np.where(tri, self._raw_uv[1], np.nan))

    @property
    def u(self):
        return self._get("uv", self._uv)[0]

    @property
    def v(self):
        return self._get("uv", self._uv)[1]

    @property
    def normal(self):
        return self._get("normal", lambda: self._surface("normal"))

    @property
    def point(self):
        return self._get("point", lambda: self._surface("point"))

    def _surface(self, field):
        return self._prepared.surface(field, self._prim, *self._raw_uv, self.t.reshape(-1),
                                      *self._rays)

    def _hit_fields(self):
        """(t, geometry_id, prim_id, uv, normal) in Open3D's dtypes, in the
        rays' shape (_Prepared.hit_fields: one pass, not a field at a time)."""
        made = self._prepared.hit_fields(self._prim, self.t.reshape(-1), *self._raw_uv)
        return tuple(self._shaped(a) for a in made)

    def __len__(self):
        return len(self.t)

    def __repr__(self):
        return f"RayHits({self.t.size} rays, {int(self.hit.sum())} hits)"


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

    def _surface(self, field):
        return self._prepared.surface(field, self._prim, *self._raw_uv, self.t, *self._rays,
                                      rows=self.ray_id)

    def __repr__(self):
        return f"HitList({len(self.ray_splits) - 1} rays, {len(self)} hits)"


class ClosestPoints(_Fields):
    """The surfaces' point closest to each of n query points
    (RayScene.closest_points), fields read as RayHits' are:

    point        (n, 3) the closest point (NaN: empty scene)
    distance     (n,) its distance from the query point (inf: empty scene)
    geometry_id  (n,) the mesh or object it is on, as in RayHits (-1: empty scene)
    prim_id      (n,) the face it is on (0 for a sphere or plane; -1: empty scene)
    u, v         (n,) barycentric weights of the face's second and third vertices
                 (NaN: sphere, plane)
    normal       (n, 3) unit geometric normal of that primitive, as RayHits'
                 (computed when first read)
    """
    FIELDS = ("point", "distance", "geometry_id", "prim_id", "u", "v", "normal")
    ALIASES = ("object_id",)

    def __init__(self, point, d2, prim, u, v, prepared, order):
        self._raw = (point, prim, u, v)     # in the kernel's (Morton) order
        self._prepared = prepared
        self._order = order
        gid, face = prepared.ids(prim)
        tri = (prim >= 0) & (prim < prepared.n_tris)
        self.point = _unsorted(point, order)
        self.distance = _unsorted(np.sqrt(d2), order)
        self.geometry_id = _unsorted(gid, order)
        self.prim_id = _unsorted(face, order)
        self.u = _unsorted(np.where(tri, u, np.nan), order)
        self.v = _unsorted(np.where(tri, v, np.nan), order)
        self._normal = None

    object_id = property(lambda self: self.geometry_id)

    @property
    def normal(self):
        if self._normal is None:
            point, prim, u, v = self._raw
            # The surface at t = 0 of a ray from the point itself.
            zero = np.broadcast_to(0.0, point.shape)
            n = self._prepared.surface("normal", prim, u, v, zero[:, 0], point, zero)
            self._normal = _unsorted(n, self._order)
        return self._normal

    def __len__(self):
        return len(self.distance)

    def __repr__(self):
        return f"ClosestPoints({len(self)} points)"
