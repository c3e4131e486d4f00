"""float32 or float64 geometry buffers?  Measures both sides of the trade.

1. Speed: a brute-force closest-hit loop (make_ray + ray_triangle, the
   renderer's own functions) compiled once for float32 and once for float64
   vertex arrays, on a small mesh that fits in cache and a large one that
   does not.  The triangle test's arithmetic is float64 either way (rays
   and the shear constants are float64, and float32 operands are promoted),
   so float32 can only save memory traffic.
2. Accuracy far from the origin: the teapot scene moved 1e3 and 1e5 from
   the origin, with every coordinate first rounded to float32 (which is
   exactly what float32 buffers would hold) or kept in float64, compared
   with the unit scene.

    PYTHONPATH=. python bench/precision.py
"""
import dataclasses
import time

import numba
import numpy as np
from numba import njit, prange

from raytrace.kernels.intersect import ray_triangle
from raytrace.kernels.ray import make_ray

REPEATS = 5


@njit(parallel=True, error_model="numpy", _nrt=False)
def brute_closest_t(v0, v1, v2, o, d, out):
    for i in prange(o.shape[0]):
        ray = make_ray(o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2])
        best = np.inf
        for p in range(v0.shape[0]):
            t, b1, b2 = ray_triangle(ray, v0, v1, v2, p, best)
            if t < best:
                best = t
        out[i] = best


def icosphere(subdivisions):
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    return v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]


def throughput(dtype, tris, n_rays, rng):
    v0, v1, v2 = (np.ascontiguousarray(a, dtype=dtype) for a in tris)
    o = rng.uniform(-0.3, 0.3, (n_rays, 3))
    d = rng.normal(size=(n_rays, 3))
    out = np.empty(n_rays)
    brute_closest_t(v0, v1, v2, o[:1], d[:1], out[:1])     # compile for this dtype
    best = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        brute_closest_t(v0, v1, v2, o, d, out)
        best = min(best, time.perf_counter() - t0)
    assert np.isfinite(out).all()                          # closed mesh, rays from inside
    return n_rays * len(v0) / best / 1e6


def rounded(scene, dtype):
    """The scene with every coordinate and length rounded through dtype."""
    from raytrace.scene.model import Mesh, Sphere

    def r(x):
        return np.asarray(np.asarray(x, dtype=np.float64).astype(dtype), dtype=np.float64)
    objs = []
    for o in scene.objects:
        if isinstance(o, Mesh):
            objs.append(dataclasses.replace(o, vertices=r(o.vertices)))
        elif isinstance(o, Sphere):
            objs.append(dataclasses.replace(o, center=tuple(r(o.center)), radius=float(r(o.radius))))
        else:
            objs.append(dataclasses.replace(o, point=tuple(r(o.point))))
    lights = [dataclasses.replace(L, position=tuple(r(L.position))) for L in scene.lights]
    cam = dataclasses.replace(scene.camera, eye=tuple(r(scene.camera.eye)),
                              look_at=tuple(r(scene.camera.look_at)))
    return dataclasses.replace(scene, objects=objs, lights=lights, camera=cam)


def main():
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    from tests.scene_transform import transform_scene

    print(f"1. brute-force triangle tests, {numba.get_num_threads()} threads, best of {REPEATS}")
    print(f"   {'mesh':<28} {'float64 Mtests/s':>17} {'float32 Mtests/s':>17}")
    for sub, n_rays in ((3, 20000), (6, 400)):
        tris = icosphere(sub)
        mb = len(tris[0]) * 9 * 8 / 2**20
        r64 = throughput(np.float64, tris, n_rays, np.random.default_rng(sub))
        r32 = throughput(np.float32, tris, n_rays, np.random.default_rng(sub))
        label = f"{len(tris[0]):,} triangles ({mb:.2f} MB f64)"
        print(f"   {label:<28} {r64:>17.1f} {r32:>17.1f}")

    print("2. teapot 160x120, soft shadows (16 samples), against the unit scene")
    print(f"   {'moved by':>9} {'buffers':>8} {'max vertex error':>17} {'pixels differing':>17} "
          f"{'max diff':>9} {'8-bit px differing':>19}")
    kw = dict(accel="bvol", shadows="soft", light_samples=16, width=160, height=120)
    base = render(teapot(), **kw)
    verts = np.asarray(teapot().objects[0].vertices)
    for shift in (0.0, 1e3, 1e5):
        for dtype in (np.float64, np.float32):
            moved = transform_scene(teapot(), 1.0, shift)
            scene = rounded(moved, dtype)
            err = np.abs(np.asarray(scene.objects[0].vertices) - shift - verts).max()
            res = render(scene, **kw)
            diff = np.abs(res.linear - base.linear).max(axis=2)
            print(f"   {shift:>9g} {np.dtype(dtype).name:>8} {err:>17.2e} {(diff > 0).sum():>17,} "
                  f"{diff.max():>9.2g} {(res.image != base.image).any(axis=2).sum():>19,}")


if __name__ == "__main__":
    main()
