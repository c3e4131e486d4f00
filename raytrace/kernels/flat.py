"""Primitive dispatch and the two flat structures: brute force and
per-object bounding volumes (the workshop's Step 4).

Conventions every structure follows (so all give the same answer):
- primitive tests get the ray's own t_max, never the best t so far; the
  caller keeps the closest with ``closer`` (ties -> smaller unified id);
- box tests get the best t so far, inclusive, so a box is skipped only if
  it starts strictly beyond the best hit.
"""
import numpy as np
from numba import njit

from .counters import BOX_TESTS, PRIM_HITS, PRIM_TESTS
from .intersect import JIT, ray_aabb, ray_plane, ray_sphere, ray_triangle


@njit(**JIT)
def closer(t, p, best_t, best_p):
    """Canonical order of hits: by distance, then by primitive id."""
    return t < best_t or (t == best_t and p < best_p)


@njit(**JIT)
def test_prim(geo, ray, p, t_max):
    """Test bounded primitive p (triangle or sphere); returns (t, b1, b2)."""
    n_tris = geo.tri_v0.shape[0]
    if p < n_tris:
        return ray_triangle(ray, geo.tri_v0, geo.tri_v1, geo.tri_v2, p, t_max)
    t = ray_sphere(ray, geo.sph_center, geo.sph_radius, p - n_tris, t_max)
    return t, 0.0, 0.0


@njit(**JIT)
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


@njit(**JIT)
def planes_occluded(geo, ray, t_max, cnt):
    for k in range(geo.pl_point.shape[0]):
        cnt[PRIM_TESTS] += 1
        if ray_plane(ray, geo.pl_point, geo.pl_normal, k, t_max) < np.inf:
            cnt[PRIM_HITS] += 1
            return True
    return False


@njit(**JIT)
def range_closest(geo, ray, first, count, t_max, best_t, best_p, best_u, best_v, cnt):
    """Closest hit among unified ids first .. first+count-1."""
    for p in range(first, first + count):
        cnt[PRIM_TESTS] += 1
        t, u, v = test_prim(geo, ray, p, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            if closer(t, p, best_t, best_p):
                best_t, best_p, best_u, best_v = t, p, u, v
    return best_t, best_p, best_u, best_v


@njit(**JIT)
def range_occluded(geo, ray, first, count, t_max, cnt):
    for p in range(first, first + count):
        cnt[PRIM_TESTS] += 1
        t, u, v = test_prim(geo, ray, p, t_max)
        if t < np.inf:
            cnt[PRIM_HITS] += 1
            return True
    return False


@njit(**JIT)
def brute_closest(geo, ray, t_max, cnt):
    n = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    return range_closest(geo, ray, 0, n, t_max, np.inf, -1, 0.0, 0.0, cnt)


@njit(**JIT)
def brute_occluded(geo, ray, t_max, cnt):
    n = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    return range_occluded(geo, ray, 0, n, t_max, cnt)


@njit(**JIT)
def bvol_closest(geo, acc, ray, t_max, cnt):
    best_t, best_p, best_u, best_v = np.inf, -1, 0.0, 0.0
    for j in range(acc.obj_start.shape[0]):
        cnt[BOX_TESTS] += 1
        if ray_aabb(ray, acc.obj_lo, acc.obj_hi, j, min(best_t, t_max)) < np.inf:
            best_t, best_p, best_u, best_v = range_closest(
                geo, ray, acc.obj_start[j], acc.obj_count[j], t_max,
                best_t, best_p, best_u, best_v, cnt)
    return best_t, best_p, best_u, best_v


@njit(**JIT)
def bvol_occluded(geo, acc, ray, t_max, cnt):
    for j in range(acc.obj_start.shape[0]):
        cnt[BOX_TESTS] += 1
        if ray_aabb(ray, acc.obj_lo, acc.obj_hi, j, t_max) < np.inf:
            if range_occluded(geo, ray, acc.obj_start[j], acc.obj_count[j], t_max, cnt):
                return True
    return False
