"""Hand-computed cases for each intersection primitive."""
import math

import numpy as np
import pytest

from raytrace.kernels.intersect import ray_aabb, ray_plane, ray_sphere, ray_triangle
from raytrace.kernels.jit import python_callable
from raytrace.kernels.ray import make_ray

# Per-ray kernel functions are compiled without Python wrappers (kernels/jit.py).
ray_aabb, ray_plane, ray_sphere, ray_triangle, make_ray = map(
    python_callable, (ray_aabb, ray_plane, ray_sphere, ray_triangle, make_ray))

INF = math.inf


def ray(o, d):
    return make_ray(*(float(x) for x in o), *(float(x) for x in d))


# --- ray-box -----------------------------------------------------------------
LO = np.array([[-1.0, -1.0, -1.0]])
HI = np.array([[1.0, 1.0, 1.0]])


@pytest.mark.parametrize("o, d, expect", [
    ((0, 0, -5), (0, 0, 1), 4.0),        # head on: enters at z = -1
    ((3, 0, -5), (0, 0, 1), INF),        # passes beside the box
    ((0, 0, 5), (0, 0, 1), INF),         # box is behind the origin
    ((0, 0, 0), (0, 0, 1), 0.0),         # starts inside: entry clamped to 0
    ((1, 0, -5), (0, 0, 1), 4.0),        # grazes the x = 1 face (axis-parallel, 0 * inf = NaN ignored)
    ((1, 1, -5), (0, 0, 1), 4.0),        # along an edge of the box
    ((-5, -5, -5), (1, 1, 1), 4.0),      # diagonal through the corner
])
def test_ray_aabb_cases(o, d, expect):
    assert ray_aabb(ray(o, d), LO, HI, 0, INF) == expect


def test_ray_aabb_negative_zero_direction():
    # -0.0 gives an inverse of -inf; the result must equal the +0.0 case.
    assert ray_aabb(ray((0.5, 0, -5), (-0.0, 0.0, 1)), LO, HI, 0, INF) == 4.0
    assert ray_aabb(ray((1.5, 0, -5), (-0.0, 0.0, 1)), LO, HI, 0, INF) == INF


def test_ray_aabb_t_max_cuts_off():
    assert ray_aabb(ray((0, 0, -5), (0, 0, 1)), LO, HI, 0, 3.9) == INF
    assert ray_aabb(ray((0, 0, -5), (0, 0, 1)), LO, HI, 0, 4.0) == 4.0


def test_ray_aabb_flat_box():
    # An axis-aligned triangle has a box of zero thickness; it must still be hit.
    lo = np.array([[-1.0, -1.0, 0.0]])
    hi = np.array([[1.0, 1.0, 0.0]])
    assert ray_aabb(ray((0.2, 0.3, -2), (0, 0, 1)), lo, hi, 0, INF) == 2.0


# --- ray-triangle ---------------------------------------------------------
V0 = np.array([[0.0, 0.0, 0.0]])
V1 = np.array([[1.0, 0.0, 0.0]])
V2 = np.array([[0.0, 1.0, 0.0]])


def tri(o, d, t_max=INF):
    return ray_triangle(ray(o, d), V0, V1, V2, 0, t_max)


def test_triangle_hit_with_barycentrics():
    t, b1, b2 = tri((0.25, 0.5, 2), (0, 0, -1))
    assert (t, b1, b2) == (2.0, 0.25, 0.5)


def test_triangle_hit_from_behind_is_two_sided():
    t, b1, b2 = tri((0.25, 0.25, -3), (0, 0, 1))
    assert (t, b1, b2) == (3.0, 0.25, 0.25)


@pytest.mark.parametrize("o, d", [
    ((0.8, 0.8, 2), (0, 0, -1)),     # outside the hypotenuse
    ((-0.1, 0.5, 2), (0, 0, -1)),    # outside edge x = 0
    ((0.25, 0.25, 2), (0, 0, 1)),    # triangle behind the origin
    ((0.25, 0.25, 0.5), (1, 0, 0)),  # parallel to the plane, above it
    ((-1, 0.25, 0), (1, 0, 0)),      # parallel, in the plane: no area seen
])
def test_triangle_misses(o, d):
    assert tri(o, d)[0] == INF


def test_triangle_edge_and_vertex_are_hit():
    assert tri((0.5, 0.0, 1), (0, 0, -1))[0] == 1.0     # on edge v0-v1
    assert tri((0.5, 0.5, 1), (0, 0, -1))[0] == 1.0     # on the hypotenuse
    assert tri((0.0, 0.0, 1), (0, 0, -1))[0] == 1.0     # on vertex v0


def test_triangle_t_max_is_exclusive():
    assert tri((0.25, 0.25, 2), (0, 0, -1), t_max=2.0)[0] == INF
    assert tri((0.25, 0.25, 2), (0, 0, -1), t_max=2.0000001)[0] == 2.0


def test_triangle_unnormalised_direction_gives_parametric_t():
    assert tri((0.25, 0.25, 2), (0, 0, -4))[0] == 0.5


# --- ray-sphere -----------------------------------------------------------
C = np.array([[0.0, 0.0, 0.0]])
R = np.array([1.0])


@pytest.mark.parametrize("o, d, expect", [
    ((0, 0, -5), (0, 0, 1), 4.0),       # front surface
    ((0, 0, 0), (0, 0, 1), 1.0),        # from the centre: the far root
    ((0, 2, -5), (0, 0, 1), INF),       # miss
    ((0, 1, -5), (0, 0, 1), 5.0),       # tangent
    ((0, 0, 5), (0, 0, 1), INF),        # sphere behind
    ((0, 0, -5), (0, 0, 2), 2.0),       # unnormalised direction
])
def test_ray_sphere_cases(o, d, expect):
    got = ray_sphere(ray(o, d), C, R, 0, INF)
    if expect == INF:
        assert got == INF
    else:
        assert got == pytest.approx(expect, rel=1e-15)


def test_ray_sphere_small_and_far_is_stable():
    # A 1e-3 sphere seen from 1e4 away: b^2 - 4ac would cancel; the
    # Ray Tracing Gems form keeps the hit.
    c = np.array([[0.0, 0.0, 1e4]])
    r = np.array([1e-3])
    t = ray_sphere(ray((0, 0, 0), (0, 0, 1)), c, r, 0, INF)
    assert abs(t - (1e4 - 1e-3)) < 1e-9


# --- ray-plane ------------------------------------------------------------
P = np.array([[0.0, 0.0, 0.0]])
N = np.array([[0.0, 1.0, 0.0]])


@pytest.mark.parametrize("o, d, expect", [
    ((0, 2, 0), (0, -1, 0), 2.0),
    ((0, 2, 0), (0, 1, 0), INF),        # pointing away
    ((0, 2, 0), (1, 0, 0), INF),        # parallel
    ((0, 0, 0), (1, 0, 0), INF),        # in the plane
    ((0, -2, 0), (0, 1, 0), 2.0),       # from below: planes are two-sided
])
def test_ray_plane_cases(o, d, expect):
    assert ray_plane(ray(o, d), P, N, 0, INF) == expect


def test_ray_aabb_in_face_plane_with_either_zero_sign():
    # Origin exactly on the face x = 0, moving parallel to it: the ray
    # touches the box, whichever sign its zero component has.
    lo = np.array([[0.0, 0.0, 0.0]])
    hi = np.array([[1.0, 1.0, 1.0]])
    for dx in (0.0, -0.0):
        assert ray_aabb(ray((0, -1, 0.5), (dx, 1, 0)), lo, hi, 0, INF) == 1.0
        assert ray_aabb(ray((1, -1, 0.5), (dx, 1, 0)), lo, hi, 0, INF) == 1.0
