"""Ray-primitive intersection tests: the innermost loops of every structure.

Every structure (brute force, bounding volumes, BVH, grid) calls these same
functions, so a triangle is hit or missed identically whichever structure
found it; that is what makes the images bit-identical.

All geometry is float64 (docs/design.md, "Precision").  Compile options: jit.py.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT

# gamma(n) = n*u / (1 - n*u) with u = 2**-53, the unit roundoff of float64
# (pbrt-v4, "Floating-point error").  Ize 2013 shows that widening the slab
# test's far bound by 1 + 2*gamma(3) makes it conservative: rounding can never
# cull a box the ray truly touches.
_U = 2.0 ** -53
GAMMA3 = 3.0 * _U / (1.0 - 3.0 * _U)
BOX_FAR_SCALE = 1.0 + 2.0 * GAMMA3


@njit(**JIT)
def _slab(o, inv, lo, hi, t0, t1):
    """Narrow [t0, t1] by one axis's slab.

    A ray parallel to the slab (inv = +-inf) whose origin lies exactly on a
    face gives 0 * inf = NaN; that axis then constrains nothing (the ray
    touches the box, so keeping it is the conservative answer) for either
    sign of zero -- with -0.0 a NaN and a -inf would otherwise cull it.
    """
    tn = (lo - o) * inv
    tf = (hi - o) * inv
    if tn == tn and tf == tf:
        if tn > tf:
            tn, tf = tf, tn
        tf *= BOX_FAR_SCALE
        if tn > t0:
            t0 = tn
        if tf < t1:
            t1 = tf
    return t0, t1


@njit(**JIT)
def ray_aabb(ray, lo, hi, i, t_max):
    """Slab test of ray against box i of (n, 3) arrays lo, hi.

    Returns the entry distance (clamped to 0) or inf on a miss.  One test
    at the end instead of one per axis: t0 only grows and t1 only shrinks,
    so the answer is the same, with fewer branches (docs/benchmarks.md,
    "Kernels").
    """
    t0, t1 = _slab(ray.ox, ray.inv_x, lo[i, 0], hi[i, 0], 0.0, t_max)
    t0, t1 = _slab(ray.oy, ray.inv_y, lo[i, 1], hi[i, 1], t0, t1)
    t0, t1 = _slab(ray.oz, ray.inv_z, lo[i, 2], hi[i, 2], t0, t1)
    if t0 > t1:
        return np.inf
    return t0


def _triangle_test(crossing):
    """The triangle test; with ``crossing`` (a compile-time constant) the
    variant that counts every crossing of a closed surface once."""
    @njit(**JIT)
    def test(ray, v0, v1, v2, i, t_max):
        return _triangle(ray, v0, v1, v2, i, t_max, crossing)
    return test


@njit(**JIT)
def _owned(dx, dy):
    """Whether a triangle owns the points of its edge with direction (dx,
    dy) in the ray's sheared plane (oriented by the triangle's winding): a
    half-plane rule, so of two opposite directions exactly one owns."""
    return dy > 0.0 or (dy == 0.0 and dx > 0.0)


@njit(**JIT)
def _triangle(ray, v0, v1, v2, i, t_max, crossing):
    """Watertight ray-triangle test (Woop, Benthin & Wald 2013; pbrt-v4).

    Returns (t, b1, b2): distance and the barycentric weights of v1 and v2,
    or (inf, 0, 0) on a miss.  Hits need ray.t_min < t < t_max.  Rays through a
    shared edge or vertex hit at least one of the triangles sharing it,
    because the edge functions are evaluated identically on both sides.

    With ``crossing`` a hit exactly on an edge or vertex counts for one
    triangle only, so that a ray crossing a closed mesh there crosses it
    once: a shared edge's function is the exact negative of its neighbour's
    (the same products, subtracted the other way), and each triangle owns
    the edge points of its edges whose direction, taken in the winding
    seen from the ray, lies in one half-plane (the rasteriser's top-left
    rule).  Where the surface folds away from the ray (a silhouette), both
    or neither triangle owns the edge, so the parity is kept.
    """
    kx, ky, kz = ray.kx, ray.ky, ray.kz
    sx, sy, sz = ray.sx, ray.sy, ray.sz
    okx, oky, okz = ray.okx, ray.oky, ray.okz
    ax = v0[i, kx] - okx
    ay = v0[i, ky] - oky
    az = v0[i, kz] - okz
    bx = v1[i, kx] - okx
    by = v1[i, ky] - oky
    bz = v1[i, kz] - okz
    cx = v2[i, kx] - okx
    cy = v2[i, ky] - oky
    cz = v2[i, kz] - okz
    # Shear so the ray runs along +z through the origin.
    ax -= sx * az
    ay -= sy * az
    bx -= sx * bz
    by -= sy * bz
    cx -= sx * cz
    cy -= sy * cz
    # Scaled barycentrics: 2D edge functions.
    e0 = bx * cy - by * cx
    e1 = cx * ay - cy * ax
    e2 = ax * by - ay * bx
    # Each test below is one branch on the comparisons combined without
    # short-circuits: on incoherent rays the outcome of each comparison is
    # a coin toss a branch of its own would mispredict.
    det = e0 + e1 + e2
    mixed = (((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0))
             & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0)))
    if mixed | (det == 0.0):
        return np.inf, 0.0, 0.0
    if crossing and (e0 == 0.0 or e1 == 0.0 or e2 == 0.0):
        s = 1.0 if det > 0.0 else -1.0
        if ((e0 == 0.0 and not _owned(s * (cx - bx), s * (cy - by)))
                or (e1 == 0.0 and not _owned(s * (ax - cx), s * (ay - cy)))
                or (e2 == 0.0 and not _owned(s * (bx - ax), s * (by - ay)))):
            return np.inf, 0.0, 0.0
    az *= sz
    bz *= sz
    cz *= sz
    t_scaled = e0 * az + e1 * bz + e2 * cz
    # Behind the origin is out; t = 0 is left to the t_min test, so that a
    # t_min of FROM_ORIGIN counts a face the ray starts on.
    bound = t_max * det
    if det < 0.0:
        out = (t_scaled > 0.0) | (t_scaled <= bound)
    else:
        out = (t_scaled < 0.0) | (t_scaled >= bound)
    inv_det = 1.0 / det
    t = t_scaled * inv_det
    if out | (not ((t > ray.t_min) & (t < t_max))):
        return np.inf, 0.0, 0.0
    return t, e1 * inv_det, e2 * inv_det


ray_triangle = _triangle_test(False)
ray_triangle_crossing = _triangle_test(True)


@njit(**JIT)
def sphere_roots(ray, center, radius, i):
    """Both roots t0 <= t1 of |o + t d - c| = r, or (inf, inf).

    Uses the discriminant form of Ray Tracing Gems ch. 7 ("Precision
    Improvements for Ray/Sphere Intersection"): r^2 - |f - (f.d/d.d) d|^2
    instead of b^2 - 4ac, which cancels catastrophically for small spheres
    far from the origin, and the stable quadratic for the roots.
    """
    dx, dy, dz = ray.dx, ray.dy, ray.dz
    fx = ray.ox - center[i, 0]
    fy = ray.oy - center[i, 1]
    fz = ray.oz - center[i, 2]
    r = radius[i]
    a = dx * dx + dy * dy + dz * dz
    b = fx * dx + fy * dy + fz * dz  # half of the usual b
    s = b / a
    lx = fx - s * dx
    ly = fy - s * dy
    lz = fz - s * dz
    h = a * (r * r - (lx * lx + ly * ly + lz * lz))
    if h < 0.0:
        return np.inf, np.inf
    c = fx * fx + fy * fy + fz * fz - r * r
    sq = np.sqrt(h)
    q = -(b + sq) if b >= 0.0 else -(b - sq)
    if q == 0.0:
        return np.inf, np.inf
    t0 = c / q
    t1 = q / a
    if t0 > t1:
        t0, t1 = t1, t0
    return t0, t1


@njit(**JIT)
def ray_sphere(ray, center, radius, i, t_max):
    """Nearest root of |o + t d - c| = r with ray.t_min < t < t_max, else inf."""
    t0, t1 = sphere_roots(ray, center, radius, i)
    if t0 > ray.t_min and t0 < t_max:
        return t0
    if t1 > ray.t_min and t1 < t_max:
        return t1
    return np.inf


@njit(**JIT)
def ray_plane(ray, point, normal, i, t_max):
    """Distance to infinite plane i with ray.t_min < t < t_max, else inf.

    A ray parallel to the plane (n.d == 0) misses, even one lying in it:
    a plane seen edge-on has no area to shade.
    """
    nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
    den = nx * ray.dx + ny * ray.dy + nz * ray.dz
    if den == 0.0:
        return np.inf
    num = nx * (point[i, 0] - ray.ox) + ny * (point[i, 1] - ray.oy) + nz * (point[i, 2] - ray.oz)
    t = num / den
    if t > ray.t_min and t < t_max:
        return t
    return np.inf
