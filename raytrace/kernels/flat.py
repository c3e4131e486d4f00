"""Primitive dispatch and the two flat structures: brute force and
per-object bounding volumes (the workshop's Step 4).

Conventions every structure follows (so all give the same answer):
- primitive tests get the ray's own t_max, never the best t so far; the
  caller keeps the closest with ``closer`` (ties -> smaller unified id);
- box tests get the best t so far, inclusive, so a box is skipped only if
  it starts strictly beyond the best hit.

Two Numba rules, measured on the bvol shadow query (4 boxes, no hits):
- early exit with ``while ... and not hit`` loops, never ``break`` or
  ``return`` inside a ``for ... in range`` loop: 127 ns a ray against 10 ns;
- read namedtuple fields into locals once, before any loop, and keep loops
  in the traversal function itself: a helper holding a loop, even inlined,
  measured 250 ns a call against 10 ns written out.
"""
import numpy as np
from numba import njit

from .counters import BOX_TESTS, PRIM_HITS, PRIM_TESTS
from .intersect import INLINE, JIT, ray_aabb, ray_plane, ray_sphere, ray_triangle


@njit(**INLINE)
def closer(t, p, best_t, best_p):
    """Canonical order of hits: by distance, then by primitive id."""
    return t < best_t or (t == best_t and p < best_p)


@njit(**INLINE)
def test_prim(geo, ray, p, t_max):
    """Test bounded primitive p (triangle or sphere); returns (t, b1, b2)."""
    n_tris = geo.tri_v0.shape[0]
    if p < n_tris:
        return ray_triangle(ray, geo.tri_v0, geo.tri_v1, geo.tri_v2, p, t_max)
    t = ray_sphere(ray, geo.sph_center, geo.sph_radius, p - n_tris, t_max)
    return t, 0.0, 0.0


@njit(**INLINE)
def planes_closest(geo, ray, t_max, best_t, best_p, best_u, best_v, cnt):
    """Infinite planes have no box: every structure tests them all."""
    base = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    for k in range(geo.pl_point.shape[0]):
        cnt[PRIM_TESTS] += 1
        t = ray_plane(ray, geo.pl_point, geo.pl_normal, k, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            if closer(t, base + k, best_t, best_p):
                best_t, best_p, best_u, best_v = t, base + k, 0.0, 0.0
    return best_t, best_p, best_u, best_v


@njit(**INLINE)
def planes_occluded(geo, ray, t_max, cnt):
    point, normal = geo.pl_point, geo.pl_normal
    n = point.shape[0]
    hit = False
    k = 0
    while k < n and not hit:
        cnt[PRIM_TESTS] += 1
        if ray_plane(ray, point, normal, k, t_max) < np.inf:
            cnt[PRIM_HITS] += 1
            hit = True
        k += 1
    return hit


@njit(**INLINE)
def brute_closest(geo, ray, t_max, cnt):
    n = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    best_t, best_p, best_u, best_v = np.inf, -1, 0.0, 0.0
    for p in range(n):
        cnt[PRIM_TESTS] += 1
        t, u, v = test_prim(geo, ray, p, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            if closer(t, p, best_t, best_p):
                best_t, best_p, best_u, best_v = t, p, u, v
    return best_t, best_p, best_u, best_v


@njit(**INLINE)
def brute_occluded(geo, ray, t_max, cnt):
    n = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    hit = False
    p = 0
    while p < n and not hit:
        cnt[PRIM_TESTS] += 1
        t, u, v = test_prim(geo, ray, p, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            hit = True
        p += 1
    return hit


@njit(**INLINE)
def bvol_closest(geo, acc, ray, t_max, cnt):
    lo, hi, start, count = acc.obj_lo, acc.obj_hi, acc.obj_start, acc.obj_count
    best_t, best_p, best_u, best_v = np.inf, -1, 0.0, 0.0
    for j in range(start.shape[0]):
        cnt[BOX_TESTS] += 1
        if ray_aabb(ray, lo, hi, j, min(best_t, t_max)) < np.inf:
            for p in range(start[j], start[j] + count[j]):
                cnt[PRIM_TESTS] += 1
                t, u, v = test_prim(geo, ray, p, t_max)
                if t < np.inf:
                    cnt[PRIM_HITS] += 1
                    if closer(t, p, best_t, best_p):
                        best_t, best_p, best_u, best_v = t, p, u, v
    return best_t, best_p, best_u, best_v


@njit(**INLINE)
def bvol_occluded(geo, acc, ray, t_max, cnt):
    lo, hi, start, count = acc.obj_lo, acc.obj_hi, acc.obj_start, acc.obj_count
    hit = False
    j = 0
    n = start.shape[0]
    while j < n and not hit:
        cnt[BOX_TESTS] += 1
        if ray_aabb(ray, lo, hi, j, t_max) < np.inf:
            p = start[j]
            end = p + count[j]
            while p < end and not hit:
                cnt[PRIM_TESTS] += 1
                t, u, v = test_prim(geo, ray, p, t_max)
                if t < np.inf:
                    cnt[PRIM_HITS] += 1
                    hit = True
                p += 1
        j += 1
    return hit
