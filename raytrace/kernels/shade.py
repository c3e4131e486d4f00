"""Surface reconstruction at a hit and Blinn-Phong shading terms."""
import numpy as np
from numba import njit

from raytrace.kernels.buffers import MAT_CHECKER
from raytrace.kernels.jit import JIT

# A checker's dark squares reflect this fraction of the material's colour.
DARK_SQUARE = 0.35


@njit(**JIT)
def _normalize(x, y, z):
    sq = x * x + y * y + z * z
    if not (sq > 1e-290 and sq < 1e290):
        # Squares over- or underflow (coordinates near the 1e100 limit):
        # divide by the largest component first.  Usual sizes never come here,
        # so their results are unchanged.
        m = max(abs(x), abs(y), abs(z))
        if not (m > 0.0 and m < np.inf):
            return 0.0, 0.0, 0.0
        x, y, z = x / m, y / m, z / m
        sq = x * x + y * y + z * z
    ln = np.sqrt(sq)
    return x / ln, y / ln, z / ln


@njit(**JIT)
def surface(geo, ray, hit):
    """Hit point, geometric and shading normals, material and size scale.

    The point is rebuilt from the primitive itself (barycentrics; sphere
    and plane reprojection), not from o + t*d, so its error scales with the
    primitive's coordinates and not with the ray's length; ``scale`` is the
    magnitude that error is relative to (used for the shadow-ray offset).
    """
    t, prim, b1, b2 = hit.t, hit.prim, hit.u, hit.v
    n_tris = geo.tri_v0.shape[0]
    n_sph = geo.sph_center.shape[0]
    if prim < n_tris:
        b0 = 1.0 - b1 - b2
        v0, v1, v2 = geo.tri_v0, geo.tri_v1, geo.tri_v2
        px = b0 * v0[prim, 0] + b1 * v1[prim, 0] + b2 * v2[prim, 0]
        py = b0 * v0[prim, 1] + b1 * v1[prim, 1] + b2 * v2[prim, 1]
        pz = b0 * v0[prim, 2] + b1 * v1[prim, 2] + b2 * v2[prim, 2]
        e1x, e1y, e1z = v1[prim, 0] - v0[prim, 0], v1[prim, 1] - v0[prim, 1], v1[prim, 2] - v0[prim, 2]
        e2x, e2y, e2z = v2[prim, 0] - v0[prim, 0], v2[prim, 1] - v0[prim, 1], v2[prim, 2] - v0[prim, 2]
        gx, gy, gz = _normalize(e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x)
        vn = geo.vtx_normal
        i0, i1, i2 = geo.tri_normal[prim, 0], geo.tri_normal[prim, 1], geo.tri_normal[prim, 2]
        sx, sy, sz = _normalize(b0 * vn[i0, 0] + b1 * vn[i1, 0] + b2 * vn[i2, 0],
                                b0 * vn[i0, 1] + b1 * vn[i1, 1] + b2 * vn[i2, 1],
                                b0 * vn[i0, 2] + b1 * vn[i1, 2] + b2 * vn[i2, 2])
        if sx == 0.0 and sy == 0.0 and sz == 0.0:
            sx, sy, sz = gx, gy, gz
        scale = 0.0
        for a in range(3):
            scale = max(scale, abs(v0[prim, a]), abs(v1[prim, a]), abs(v2[prim, a]))
        mat = geo.tri_mat[prim]
    elif prim < n_tris + n_sph:
        k = prim - n_tris
        cx, cy, cz = geo.sph_center[k, 0], geo.sph_center[k, 1], geo.sph_center[k, 2]
        r = geo.sph_radius[k]
        gx, gy, gz = _normalize(ray.ox + t * ray.dx - cx, ray.oy + t * ray.dy - cy, ray.oz + t * ray.dz - cz)
        px, py, pz = cx + r * gx, cy + r * gy, cz + r * gz
        sx, sy, sz = gx, gy, gz
        scale = max(abs(cx), abs(cy), abs(cz)) + r
        mat = geo.sph_mat[k]
    else:
        k = prim - n_tris - n_sph
        gx, gy, gz = geo.pl_normal[k, 0], geo.pl_normal[k, 1], geo.pl_normal[k, 2]
        qx, qy, qz = geo.pl_point[k, 0], geo.pl_point[k, 1], geo.pl_point[k, 2]
        px, py, pz = ray.ox + t * ray.dx, ray.oy + t * ray.dy, ray.oz + t * ray.dz
        off = (px - qx) * gx + (py - qy) * gy + (pz - qz) * gz
        px, py, pz = px - off * gx, py - off * gy, pz - off * gz
        sx, sy, sz = gx, gy, gz
        scale = max(abs(px), abs(py), abs(pz), abs(qx), abs(qy), abs(qz))
        mat = geo.pl_mat[k]
    return px, py, pz, gx, gy, gz, sx, sy, sz, mat, scale


@njit(**JIT)
def smooth_point(geo, hit, px, py, pz, side):
    """The shading point lifted towards the smooth surface the vertex
    normals imply (Hanika 2021, "Hacking the Shadow Terminator", Ray
    Tracing Gems II ch. 4), where shadow rays start.

    Each vertex's tangent plane (its position and shading normal, times
    ``side``: -1 where the viewer sees the back) takes the point to itself
    if the point lies on or above that plane, and projects it onto the
    plane if below; the result is the barycentric blend of the three.  On
    a convex patch the point rises off the flat facet, so shadow rays near
    the terminator clear the neighbouring facets as they would clear the
    curved surface; on a concave patch or a flat triangle (vertex normals
    equal to the facet's) it stays put.  Spheres and planes are unchanged.
    """
    prim = hit.prim
    if prim >= geo.tri_v0.shape[0]:
        return px, py, pz
    b1, b2 = hit.u, hit.v
    qx = qy = qz = 0.0
    for corner in range(3):
        if corner == 0:
            v, b = geo.tri_v0, 1.0 - b1 - b2
        elif corner == 1:
            v, b = geo.tri_v1, b1
        else:
            v, b = geo.tri_v2, b2
        k = geo.tri_normal[prim, corner]
        n = geo.vtx_normal
        nx, ny, nz = side * n[k, 0], side * n[k, 1], side * n[k, 2]
        # Height of the point over this vertex's tangent plane; only a
        # point below it is moved (by -below along the normal).
        below = min(0.0, (px - v[prim, 0]) * nx + (py - v[prim, 1]) * ny + (pz - v[prim, 2]) * nz)
        qx -= b * below * nx
        qy -= b * below * ny
        qz -= b * below * nz
    return px + qx, py + qy, pz + qz


@njit(**JIT)
def _plane_tangents(geo, k):
    """Orthonormal tangents of plane k from its normal (Duff et al. 2017,
    "Building an Orthonormal Basis, Revisited"), so the pattern lies in
    the plane and does not flicker with the sign of rounding across it."""
    nx, ny, nz = geo.pl_normal[k, 0], geo.pl_normal[k, 1], geo.pl_normal[k, 2]
    sign = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sign + nz)
    bb = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * bb, -sign * nx,
            bb, sign + ny * ny * a, -ny)


@njit(**JIT)
def _checker_size(geo, prim, mat):
    """The checker's square size if prim is a checkered plane, else 0."""
    size = geo.mat_param[mat, MAT_CHECKER]
    if size > 0.0 and prim >= geo.tri_v0.shape[0] + geo.sph_center.shape[0]:
        return size
    return 0.0


@njit(**JIT)
def _shaded(geo, mat, dark):
    """The material's colour where fraction ``dark`` of the area is on
    dark squares."""
    f = (1.0 - dark) + dark * DARK_SQUARE
    return f * geo.mat_color[mat, 0], f * geo.mat_color[mat, 1], f * geo.mat_color[mat, 2]


@njit(**JIT)
def albedo(geo, prim, mat, px, py, pz):
    """Material colour; planes with a checker size alternate full and 35 %,
    sampled at the point (aliases where a square is smaller than a pixel)."""
    size = _checker_size(geo, prim, mat)
    if size == 0.0:
        return geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    k = prim - geo.tri_v0.shape[0] - geo.sph_center.shape[0]
    t1x, t1y, t1z, t2x, t2y, t2z = _plane_tangents(geo, k)
    dx = px - geo.pl_point[k, 0]
    dy = py - geo.pl_point[k, 1]
    dz = pz - geo.pl_point[k, 2]
    u = np.floor((dx * t1x + dy * t1y + dz * t1z) / size)
    v = np.floor((dx * t2x + dy * t2y + dz * t2z) / size)
    r, g, b = geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    if (int(u) + int(v)) & 1:
        return DARK_SQUARE * r, DARK_SQUARE * g, DARK_SQUARE * b
    return r, g, b


@njit(**JIT)
def _odd_length(x):
    """Length of the part of [0, x] where floor is odd: the integral of
    the 1-D square wave floor(x) mod 2, which is 0 on [0, 1) and 1 on
    [1, 2): one per whole period of 2, plus the part of the last one past 1."""
    periods = np.floor(0.5 * x)
    return periods + max(0.0, x - 2.0 * periods - 1.0)


@njit(**JIT)
def _odd_fraction(c, half):
    """Fraction of [c - half, c + half] where floor is odd."""
    if not half < np.inf:
        return 0.5
    if half == 0.0:
        return float(int(np.floor(c)) & 1)
    return (_odd_length(c + half) - _odd_length(c - half)) / (2.0 * half)


@njit(**JIT)
def checker_box(u, v, hu, hv):
    """Fraction of the box [u - hu, u + hu] x [v - hv, v + hv] that lies on
    odd squares (floor(u) + floor(v) odd): the checker integrated over the
    box in closed form, as pbrt's box-filtered checkerboard does (Pharr,
    Jakob & Humphreys, Physically Based Rendering, 3rd ed., sec. 10.5,
    "Checkerboard").  u and v are independent under the box, and a square
    is odd when exactly one of its coordinates is."""
    fu = _odd_fraction(u, hu)
    fv = _odd_fraction(v, hv)
    return fu + fv - 2.0 * fu * fv


@njit(**JIT)
def albedo_filtered(geo, cam, prim, mat, px, py, pz, sxn, syn, step_x, step_y):
    """Material colour; a checkered plane's pattern is averaged over the
    camera sample's footprint on the plane, so it fades to the mean of its
    two colours where a square is smaller than a pixel instead of aliasing.

    The footprint comes from ray differentials (Igehy 1999, "Tracing Ray
    Differentials"): the pinhole's ray through screen position (sxn, syn)
    is d = forward + sxn right + syn up, unnormalised, and it meets the
    plane at p = eye + t d with t = (q - eye).n / d.n.  Moving sxn by ds
    moves p by dp/dsxn ds, dp/dsxn = t (right - d (right.n) / (d.n)), and
    likewise for syn; a sample covers step_x by step_y of the screen.  The
    checker is box-filtered over the bounding box in (u, v) of that
    parallelogram.
    """
    size = _checker_size(geo, prim, mat)
    if size == 0.0:
        return geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    k = prim - geo.tri_v0.shape[0] - geo.sph_center.shape[0]
    t1x, t1y, t1z, t2x, t2y, t2z = _plane_tangents(geo, k)
    nx, ny, nz = geo.pl_normal[k, 0], geo.pl_normal[k, 1], geo.pl_normal[k, 2]
    qx, qy, qz = geo.pl_point[k, 0], geo.pl_point[k, 1], geo.pl_point[k, 2]
    dx = cam[3] + sxn * cam[6] + syn * cam[9]
    dy = cam[4] + sxn * cam[7] + syn * cam[10]
    dz = cam[5] + sxn * cam[8] + syn * cam[11]
    dn = dx * nx + dy * ny + dz * nz
    t = ((qx - cam[0]) * nx + (qy - cam[1]) * ny + (qz - cam[2]) * nz) / dn
    rn = (cam[6] * nx + cam[7] * ny + cam[8] * nz) / dn
    un = (cam[9] * nx + cam[10] * ny + cam[11] * nz) / dn
    # dp/dsxn and dp/dsyn, scaled by the sample's extent on the screen.
    sa, sb = t * step_x, t * step_y
    ax, ay, az = sa * (cam[6] - dx * rn), sa * (cam[7] - dy * rn), sa * (cam[8] - dz * rn)
    bx, by, bz = sb * (cam[9] - dx * un), sb * (cam[10] - dy * un), sb * (cam[11] - dz * un)
    # Half extents of the footprint along the tangents, in squares.
    hu = 0.5 * (abs(ax * t1x + ay * t1y + az * t1z) + abs(bx * t1x + by * t1y + bz * t1z)) / size
    hv = 0.5 * (abs(ax * t2x + ay * t2y + az * t2z) + abs(bx * t2x + by * t2y + bz * t2z)) / size
    ex, ey, ez = px - qx, py - qy, pz - qz
    u = (ex * t1x + ey * t1y + ez * t1z) / size
    v = (ex * t2x + ey * t2y + ez * t2z) / size
    return _shaded(geo, mat, checker_box(u, v, hu, hv))
