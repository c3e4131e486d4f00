"""Primitive dispatch: the one place that knows a unified primitive id
names a triangle, a sphere or a plane (kernels/buffers.py).

Conventions every structure follows, so all give the same answer:
- primitive tests get the ray's own t_max, never the best t so far; the
  caller keeps the closest with ``closer`` (ties: the smaller id);
- box tests get min(best t, t_max), inclusive, so a box is skipped only if
  it starts strictly beyond the best hit.
"""
import numpy as np
from numba import njit
from numba.extending import overload

from raytrace.kernels import buffers
from raytrace.kernels.counters import PRIM_HITS, PRIM_TESTS
from raytrace.kernels.intersect import (
    ray_plane,
    ray_sphere,
    ray_triangle,
    ray_triangle_crossing,
    sphere_roots,
)
from raytrace.kernels.jit import JIT, OVERLOAD
from raytrace.kernels.ray import CrossingRay, Hit, ListingRay, closer, no_hit

# buffers.n_bounded compiled: the primitives with a box (triangles, then
# spheres), the ones structures hold.
n_bounded = njit(**JIT)(buffers.n_bounded)


def test_prim(geo, ray, p, t_max):
    """Test bounded primitive p (triangle or sphere); returns (t, b1, b2).
    Chosen by the ray's type: a CrossingRay's test counts each crossing of
    a closed surface once; a ListingRay's also writes down each hit
    (record_hit).  Compiled code only."""
    raise NotImplementedError("compiled code only")


@njit(**JIT)
def _test_prim(geo, ray, p, t_max):
    n_tris = geo.tri_v0.shape[0]
    if p < n_tris:
        return ray_triangle(ray, geo.tri_v0, geo.tri_v1, geo.tri_v2, p, t_max)
    t = ray_sphere(ray, geo.sph_center, geo.sph_radius, p - n_tris, t_max)
    return t, 0.0, 0.0


@njit(**JIT)
def _test_prim_crossing(geo, ray, p, t_max):
    n_tris = geo.tri_v0.shape[0]
    if p < n_tris:
        return ray_triangle_crossing(ray, geo.tri_v0, geo.tri_v1, geo.tri_v2, p, t_max)
    # A sphere's roots count from t_min exclusive: a tangent ray's double
    # root is one hit.
    return ray_sphere(ray, geo.sph_center, geo.sph_radius, p - n_tris, t_max), 0.0, 0.0


@njit(**JIT)
def record_hit(ray, t, p, u, v):
    """Write a hit at a ListingRay's cursor and move it on; a row at or past
    cursor[1] is not written, only counted."""
    j = ray.cursor[0]
    if j < ray.cursor[1]:
        ray.hit_t[j] = t
        ray.hit_prim[j] = p
        ray.hit_u[j] = u
        ray.hit_v[j] = v
    ray.cursor[0] = j + 1


@njit(**JIT)
def _test_prim_listing(geo, ray, p, t_max):
    t, u, v = _test_prim_crossing(geo, ray, p, t_max)
    if t < np.inf:
        record_hit(ray, t, p, u, v)
    return t, u, v


@overload(test_prim, jit_options=OVERLOAD)
def _choose_test_prim(geo, ray, p, t_max):
    cls = ray.instance_class
    test = (_test_prim_listing if cls is ListingRay else
            _test_prim_crossing if cls is CrossingRay else _test_prim)

    def impl(geo, ray, p, t_max):
        return test(geo, ray, p, t_max)
    return impl


def records_hits(ray):
    """Whether test_prim writes the ray's hits down (a ListingRay): a
    compile-time constant.  Compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(records_hits, jit_options=OVERLOAD)
def _records_hits(ray):
    listing = ray.instance_class is ListingRay

    def impl(ray):
        return listing
    return impl


@njit(**JIT)
def test_and_keep(geo, ray, p, t_max, best, cnt, keep):
    """Test bounded primitive p and count it; returns the closer of its hit
    and best, or with keep False (counting every hit) best unchanged.  The
    loop body of every structure but the BVH, which counts in locals."""
    cnt[PRIM_TESTS] += 1
    t, u, v = test_prim(geo, ray, p, t_max)
    if t < np.inf:
        cnt[PRIM_HITS] += 1
        if keep and closer(t, p, best):
            return Hit(t, p, u, v)
    return best


@njit(**JIT)
def _far_root(geo, ray, k, t_max):
    """Sphere k's far root if both its roots lie in t_min < t < t_max, else
    inf: a primitive test reports one hit a sphere (the near root), and a
    ray through a sphere crosses it twice."""
    t0, t1 = sphere_roots(ray, geo.sph_center, geo.sph_radius, k)
    if t0 > ray.t_min and t1 < t_max and t0 < t1:
        return t1
    return np.inf


@njit(**JIT)
def far_sphere_roots(geo, ray, t_max):
    """How many spheres the ray passes through, both roots in its interval.
    A loop over every sphere: scenes hold few."""
    n = 0
    for k in range(geo.sph_center.shape[0]):
        n += _far_root(geo, ray, k, t_max) < np.inf
    return n


@njit(**JIT)
def count_unbounded_hits(geo, ray, t_max, cnt):
    """How many hits a ray has that no structure holds: planes (each hit
    also counted in cnt[PRIM_HITS], as a traversal counts its own) and
    spheres' far roots.  The ones record_unbounded_hits writes down."""
    before = cnt[PRIM_HITS]
    planes_closest(geo, ray, t_max, no_hit(), cnt)
    return cnt[PRIM_HITS] - before + far_sphere_roots(geo, ray, t_max)


@njit(**JIT)
def record_unbounded_hits(geo, ray, t_max):
    """A ListingRay's hits that no structure holds: spheres' far roots and
    planes (the ones count_hits adds to its traversal's)."""
    n_tris = geo.tri_v0.shape[0]
    for k in range(geo.sph_center.shape[0]):
        t = _far_root(geo, ray, k, t_max)
        if t < np.inf:
            record_hit(ray, t, n_tris + k, 0.0, 0.0)
    base = n_bounded(geo)
    for k in range(geo.pl_point.shape[0]):
        t = ray_plane(ray, geo.pl_point, geo.pl_normal, k, t_max)
        if t < np.inf:
            record_hit(ray, t, base + k, 0.0, 0.0)


@njit(**JIT)
def planes_closest(geo, ray, t_max, best, cnt):
    """Infinite planes have no box: every structure tests them all, after
    its own primitives; returns the closer of best and the planes' hits."""
    base = n_bounded(geo)
    for k in range(geo.pl_point.shape[0]):
        cnt[PRIM_TESTS] += 1
        t = ray_plane(ray, geo.pl_point, geo.pl_normal, k, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            if closer(t, base + k, best):
                best = Hit(t, base + k, 0.0, 0.0)
    return best


@njit(**JIT)
def planes_occluded(geo, ray, t_max, cnt):
    """Whether any plane is hit with 0 < t < t_max.  Early exits are loop
    conditions: a return inside a for loop compiles to much slower code
    (docs/history.md)."""
    point, normal = geo.pl_point, geo.pl_normal
    n = point.shape[0]
    hit = False
    k = np.int64(0)    # not a literal 0: ray_plane was compiled again for it
    while k < n and not hit:
        cnt[PRIM_TESTS] += 1
        if ray_plane(ray, point, normal, k, t_max) < np.inf:
            cnt[PRIM_HITS] += 1
            hit = True
        k += 1
    return hit
