"""Surface reconstruction at a hit and Blinn-Phong shading terms."""
import numpy as np
from numba import njit

from ..buffers import MAT_CHECKER
from .jit import JIT


@njit(**JIT)
def _normalize(x, y, z):
    ln = np.sqrt(x * x + y * y + z * z)
    if ln == 0.0:
        return 0.0, 0.0, 0.0
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
        n0, n1, n2 = geo.tri_n0, geo.tri_n1, geo.tri_n2
        sx, sy, sz = _normalize(b0 * n0[prim, 0] + b1 * n1[prim, 0] + b2 * n2[prim, 0],
                                b0 * n0[prim, 1] + b1 * n1[prim, 1] + b2 * n2[prim, 1],
                                b0 * n0[prim, 2] + b1 * n1[prim, 2] + b2 * n2[prim, 2])
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
            v, n, b = geo.tri_v0, geo.tri_n0, 1.0 - b1 - b2
        elif corner == 1:
            v, n, b = geo.tri_v1, geo.tri_n1, b1
        else:
            v, n, b = geo.tri_v2, geo.tri_n2, b2
        nx, ny, nz = side * n[prim, 0], side * n[prim, 1], side * n[prim, 2]
        # Height of the point over this vertex's tangent plane; only a
        # point below it is moved (by -below along the normal).
        below = min(0.0, (px - v[prim, 0]) * nx + (py - v[prim, 1]) * ny + (pz - v[prim, 2]) * nz)
        qx -= b * below * nx
        qy -= b * below * ny
        qz -= b * below * nz
    return px + qx, py + qy, pz + qz


@njit(**JIT)
def albedo(geo, prim, mat, px, py, pz):
    """Material colour; planes with a checker size alternate full and 35 %."""
    r, g, b = geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    size = geo.mat_param[mat, MAT_CHECKER]
    base = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    if size > 0.0 and prim >= base:
        k = prim - base
        nx, ny, nz = geo.pl_normal[k, 0], geo.pl_normal[k, 1], geo.pl_normal[k, 2]
        # Orthonormal tangents from the normal (Duff et al. 2017, "Building
        # an Orthonormal Basis, Revisited"), so the pattern lies in the plane
        # and does not flicker with the sign of rounding across it.
        sign = 1.0 if nz >= 0.0 else -1.0
        a = -1.0 / (sign + nz)
        bb = nx * ny * a
        t1x, t1y, t1z = 1.0 + sign * nx * nx * a, sign * bb, -sign * nx
        t2x, t2y, t2z = bb, sign + ny * ny * a, -ny
        dx = px - geo.pl_point[k, 0]
        dy = py - geo.pl_point[k, 1]
        dz = pz - geo.pl_point[k, 2]
        u = np.floor((dx * t1x + dy * t1y + dz * t1z) / size)
        v = np.floor((dx * t2x + dy * t2y + dz * t2z) / size)
        if (int(u) + int(v)) & 1:
            return 0.35 * r, 0.35 * g, 0.35 * b
    return r, g, b
