"""Point queries: the closest point of the surfaces to each query point,
through the BVH (whatever structure a RayScene casts rays with).

The traversal keeps a stack of child nodes ordered by the squared distance
from the point to their boxes, nearest on top, and skips any box farther
than the best point found so far (the point-query form of the ray
traversal in traverse.py).  Ties between primitives at the same distance go to
the smaller id, so the answer does not depend on the visiting order.
"""
import functools

import numpy as np
from numba import njit

from raytrace.accel.bvh.layout import MAX_DEPTH, WIDTH
from raytrace.kernels.entry import entry_of
from raytrace.kernels.jit import BLOCK, JIT
from raytrace.kernels.lowlevel import frame_array, take_ticket
from raytrace.kernels.packed import unpack
from raytrace.kernels.threads import run_on_threads

STACK_SIZE = 3 * MAX_DEPTH + 4
CHUNK = 64


@njit(**JIT)
def closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Closest point of triangle abc to p and its barycentric weights of b
    and c: (x, y, z, u, v).  Voronoi regions of the vertices, then the
    edges, then the face (Ericson, "Real-Time Collision Detection" 5.1.5)."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, 0.0, 0.0
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bx, by, bz, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        w = d1 / (d1 - d3)
        return ax + w * abx, ay + w * aby, az + w * abz, w, 0.0
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cx, cy, cz, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz, 0.0, w
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return bx + w * (cx - bx), by + w * (cy - by), bz + w * (cz - bz), 1.0 - w, w
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w, v, w


@njit(**JIT)
def closest_on_prim(geo, p, qx, qy, qz):
    """(x, y, z, u, v) of bounded primitive p's point closest to q."""
    n_tris = geo.tri_v0.shape[0]
    if p < n_tris:
        a, b, c = geo.tri_v0, geo.tri_v1, geo.tri_v2
        return closest_on_triangle(qx, qy, qz, a[p, 0], a[p, 1], a[p, 2],
                                   b[p, 0], b[p, 1], b[p, 2], c[p, 0], c[p, 1], c[p, 2])
    k = p - n_tris
    cx, cy, cz = geo.sph_center[k, 0], geo.sph_center[k, 1], geo.sph_center[k, 2]
    r = geo.sph_radius[k]
    dx, dy, dz = qx - cx, qy - cy, qz - cz
    ln = np.sqrt(dx * dx + dy * dy + dz * dz)
    if ln == 0.0:          # the centre: every point of the sphere is closest
        return cx + r, cy, cz, 0.0, 0.0
    return cx + r * dx / ln, cy + r * dy / ln, cz + r * dz / ln, 0.0, 0.0


@njit(**JIT)
def _keep(d2, p, x, y, z, u, v, best):
    """The closer of (d2, p, ...) and best, ties to the smaller id."""
    if d2 < best[0] or (d2 == best[0] and p < best[1]):
        return (d2, p, x, y, z, u, v)
    return best


@njit(**JIT)
def _box_d2(node_box, node, lane, qx, qy, qz):
    d2 = 0.0
    for a, q in enumerate((qx, qy, qz)):
        lo = node_box[node, a, lane]
        hi = node_box[node, 3 + a, lane]
        if q < lo:
            d2 += (lo - q) * (lo - q)
        elif q > hi:
            d2 += (q - hi) * (q - hi)
    return d2


@njit(**JIT)
def closest_point(geo, bvh, qx, qy, qz):
    """(d2, prim, x, y, z, u, v) of the surfaces' point closest to q;
    prim -1 if there is nothing."""
    best = (np.inf, np.int64(-1), 0.0, 0.0, 0.0, 0.0, 0.0)   # not a literal -1 (_keep once)
    base = geo.tri_v0.shape[0] + geo.sph_center.shape[0]
    for k in range(geo.pl_point.shape[0]):     # planes: no box, tested first
        nx, ny, nz = geo.pl_normal[k, 0], geo.pl_normal[k, 1], geo.pl_normal[k, 2]
        off = ((qx - geo.pl_point[k, 0]) * nx + (qy - geo.pl_point[k, 1]) * ny
               + (qz - geo.pl_point[k, 2]) * nz)
        best = _keep(off * off, base + k, qx - off * nx, qy - off * ny, qz - off * nz, 0.0, 0.0,
                     best)
    node_box, node_child, node_count, prim_ids = (bvh.node_box, bvh.node_child,
                                                  bvh.node_count, bvh.prim_ids)
    if node_box.shape[0] == 0:
        return best
    stack = frame_array(STACK_SIZE, np.int64)
    stack_d = frame_array(STACK_SIZE, np.float64)
    sp = 1
    stack[0] = 0
    stack_d[0] = 0.0
    while sp > 0:
        sp -= 1
        node = stack[sp]
        if stack_d[sp] > best[0]:
            continue
        base_sp = sp
        for lane in range(WIDTH):
            d2 = _box_d2(node_box, node, lane, qx, qy, qz)
            if d2 <= best[0]:
                if node_count[node, lane] > 0:
                    start = node_child[node, lane]
                    for j in range(start, start + node_count[node, lane]):
                        p = prim_ids[j]
                        x, y, z, u, v = closest_on_prim(geo, p, qx, qy, qz)
                        dd = (x - qx) * (x - qx) + (y - qy) * (y - qy) + (z - qz) * (z - qz)
                        best = _keep(dd, p, x, y, z, u, v, best)
                else:
                    # Insert nearest on top, as the ray traversal does.
                    k = sp
                    while k > base_sp and stack_d[k - 1] < d2:
                        stack[k] = stack[k - 1]
                        stack_d[k] = stack_d[k - 1]
                        k -= 1
                    stack[k] = node_child[node, lane]
                    stack_d[k] = d2
                    sp += 1
    return best


@njit(**BLOCK)
def _points_block(scene, points, out_point, out_prim, out_u, out_v, out_d2, clock):
    geo, bvh = unpack(scene)
    n = points.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    c = take_ticket(clock)     # the next chunk nobody has taken, as in kernels/cast.py
    while c < n_chunks:
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            d2, p, x, y, z, u, v = closest_point(geo, bvh, points[i, 0], points[i, 1],
                                                 points[i, 2])
            out_d2[i] = d2
            out_prim[i] = p
            out_point[i, 0] = x
            out_point[i, 1] = y
            out_point[i, 2] = z
            out_u[i] = u
            out_v[i] = v
        c = take_ticket(clock)


def closest_points(scene, points, out_point, out_prim, out_u, out_v, out_d2, n_blocks, clock,
                   entries=None):
    """The surfaces' closest point to each query point, its primitive, its
    barycentric weights (triangles) and the squared distance; n_blocks
    threads take chunks of points by ticket from clock (0 at the call).
    scene: the geometry and a BVH packed (kernels/cast.py ray_scene);
    through the block's compiled entry kept in ``entries`` if given (a
    prepared scene's, as kernels/cast.py run_blocks)."""
    block = entry_of(_points_block, entries)
    run_on_threads([functools.partial(block, scene, points, out_point, out_prim, out_u,
                                      out_v, out_d2, clock)] * n_blocks)
