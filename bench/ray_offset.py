"""How far off the surface must a shadow ray start?  Measures self-hits
("shadow acne") against the offset, to choose RAY_OFFSET (kernels/render.py).

For each surface (a sphere, a triangulated icosphere, a plane) at several
scales and distances from the origin, camera-like rays are cast with
raytrace.cast_rays; the hit point is rebuilt from the primitive the way the
renderer does it (barycentrics; sphere and plane reprojection); then for
each offset k the shadow ray starts at p + 2^k * M * n (M: the magnitude
of the coordinates, n: the geometric normal facing the viewer) towards a
point light on the lit side, and every occluded one is a self-hit: these
surfaces are convex (or flat), so nothing else can be in the way.

    PYTHONPATH=. python bench/ray_offset.py
"""
import numpy as np

from raytrace import cast_rays, occluded
from raytrace.scene.model import Camera, Plane, Scene, Sphere

N_RAYS = 200_000
OFFSETS = range(-56, -27, 2)           # 2^-56 (half an ulp) .. 2^-28
CASES = [(1.0, 0.0), (1e-4, 0.0), (1e4, 0.0), (1.0, 1e5), (1e-4, 1e5)]


def unit(a):
    return a / np.linalg.norm(a, axis=1)[:, None]


def camera_rays(rng, centre, size):
    d = unit(rng.normal(size=(N_RAYS, 3)))
    o = centre - 3 * size * d
    return o, centre + rng.uniform(-0.7, 0.7, (N_RAYS, 3)) * size - o


def hit_points(kind, size, shift, rng):
    """(target, p, n, M) for the rays that hit."""
    c = np.full(3, shift)
    if kind == "sphere":
        target = Scene("s", Camera((0, 0, 1), (0, 0, 0)), [Sphere(tuple(c), size)])
    elif kind == "plane":
        target = Scene("p", Camera((0, 0, 1), (0, 0, 0)), [Plane(tuple(c), (0.3, 1.0, 0.2))])
    else:
        import trimesh
        m = trimesh.creation.icosphere(3)
        target = (m.vertices * size + c, np.asarray(m.faces))
    o, d = camera_rays(rng, c, size)
    h = cast_rays(target, o, d, accel="bvol")
    o, d, t = o[h.hit], d[h.hit], h.t[h.hit][:, None]
    if kind == "sphere":            # kernels/shade.py: c + r * normalize(o + t d - c)
        n = unit(o + t * d - c)
        p = c + size * n
        mag = np.maximum(np.abs(c).max() + size, np.abs(p).max(axis=1))
    elif kind == "plane":           # o + t d, projected onto the plane
        n = np.tile(unit(np.array([[0.3, 1.0, 0.2]])), (len(o), 1))
        p = o + t * d
        p -= np.einsum("ij,ij->i", p - c, n)[:, None] * n
        mag = np.maximum(np.abs(p).max(axis=1), np.abs(c).max())
    else:                           # barycentric weights of the three vertices
        v, f = target
        a, b, cc = (v[f[h.prim_id[h.hit], k]] for k in range(3))
        u, w = h.u[h.hit][:, None], h.v[h.hit][:, None]
        p = (1 - u - w) * a + u * b + w * cc
        n = unit(np.cross(b - a, cc - a))
        mag = np.maximum(np.abs(np.stack([a, b, cc])).max(axis=(0, 2)), np.abs(p).max(axis=1))
    n[np.einsum("ij,ij->i", n, d) > 0] *= -1
    return target, p, n, mag


def main():
    rng = np.random.default_rng(0)
    print(f"self-hits of shadow rays out of the lit points ({N_RAYS:,} camera rays each)")
    print(f"{'surface':<8} {'scale':>6} {'shift':>6}  " + " ".join(f"{f'2^{k}':>7}" for k in OFFSETS))
    for kind in ("sphere", "ico", "plane"):
        for size, shift in CASES:
            target, p, n, mag = hit_points(kind, size, shift, rng)
            light = shift + size * np.array([1.5, 5.0, 1.0])
            lit = np.einsum("ij,ij->i", n, light - p) > 0
            p, n, mag = p[lit], n[lit], mag[lit]
            counts = []
            for k in OFFSETS:
                q = p + (2.0 ** k * mag)[:, None] * n
                counts.append(int(occluded(target, q, light - q, 1.0, accel="bvol").sum()))
            print(f"{kind:<8} {size:>6g} {shift:>6g}  " + " ".join(f"{c:>7}" for c in counts)
                  + f"   of {len(p):,}")


if __name__ == "__main__":
    main()
