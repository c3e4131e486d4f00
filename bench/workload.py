"""The public workload suite (issue 40): the rays users cast, on the teapot
mesh alone, through RayScene and through each peer that imports.

    bash bench.sh --sections workload [--quick]

Meshes: the teapot at details 4, 43 and 128 (1,024, 118,336 and
1,048,576 triangles; --quick: the first two, 320x240 rays, 3 rounds),
without its ground plane.  Ray sets per mesh, made once in NumPy
(float64), the seed fixed:

camera       640x480 pixel centres of the scene's camera, image order
shuffled     the same rays in a random order
box          origins uniform on a sphere around the mesh's box (twice its
             half diagonal), directions towards uniform points of the box
shadow-point from each hit of `camera`, offset along the normal facing the
             viewer, to the point light (t_max 1; lit hits only, as the
             renderer casts them)
shadow-area  the same to uniform points of the light's square
bounce       from the same points, cosine-distributed about that normal
camera f32, box f32   `camera` and `box` as float32 arrays

Queries: closest hit (RayScene.cast_rays), any hit (occluded) and count
(count_intersections), where the set asks it.  Scenes are built before
timing.  Peers get the same rays in their natural dtype (float32), made
before timing; a call's conversion of them into its own types is timed.
"""
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from common import fmt_g, log, markdown_table, median

DETAILS_FULL = (4, 43, 128)
DETAILS_QUICK = (4, 43)
SIZE_FULL, SIZE_QUICK = (640, 480), (320, 240)   # camera rays; as many box rays
SEED = 40
OFFSET = 1e-4     # off the surface along the facing normal (about 200 float32 ulps at 1)
THREADS = 2

# (set, queries): any-hit rays end at the light (t_max 1); count asks how
# often a ray crosses the surface, which the shadow and bounce rays do not.
ROWS = (
    ("camera", ("closest", "any", "count")),
    ("shuffled", ("closest", "any", "count")),
    ("box", ("closest", "any", "count")),
    ("shadow-point", ("any",)),
    ("shadow-area", ("any",)),
    ("bounce", ("closest", "any")),
    ("camera f32", ("closest", "any", "count")),
    ("box f32", ("closest", "any", "count")),
)


# ---- ray sets (pure NumPy; tests/test_workload.py checks them) ----------

def camera_rays(camera, width, height):
    """(origins, unit directions) through the pixel centres, row by row."""
    from raytrace.renderer.driver import camera_buffer
    cam = camera_buffer(camera, width, height)
    eye, fwd, right, up = cam[0:3], cam[3:6], cam[6:9], cam[9:12]
    sx, sy = np.meshgrid(2 * (np.arange(width) + 0.5) / width - 1,
                         1 - 2 * (np.arange(height) + 0.5) / height)
    d = fwd + sx.reshape(-1, 1) * right + sy.reshape(-1, 1) * up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(np.broadcast_to(eye, d.shape)), d


def shuffled(rays, rng):
    """The same rays in a random order: (arrays..., the permutation)."""
    perm = rng.permutation(len(rays[0]))
    return tuple(np.ascontiguousarray(a[perm]) for a in rays) + (perm,)


def box_rays(lo, hi, n, rng):
    """n rays from uniform points of a sphere around the box [lo, hi]
    (centred on it, radius twice its half diagonal) towards uniform points
    of the box: (origins, unit directions)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    s = rng.normal(size=(n, 3))
    o = centre + radius * s / np.linalg.norm(s, axis=1, keepdims=True)
    d = lo + rng.uniform(size=(n, 3)) * (hi - lo) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def surface(vertices, faces, origins, directions, prim, t):
    """(points, unit normals facing the ray's origin) of the rays with a
    hit (prim >= 0), in their order."""
    hit = prim >= 0
    p = origins[hit] + t[hit, None] * directions[hit]
    tri = faces[prim[hit]]
    v0 = vertices[tri[:, 0]]
    n = np.cross(vertices[tri[:, 1]] - v0, vertices[tri[:, 2]] - v0)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n *= -np.sign(np.sum(n * directions[hit], axis=1, keepdims=True))
    return p, n


def shadow_rays(points, normals, targets):
    """Rays from just off each point to its target (one (3,) point or one
    per point), unnormalised so the target is at t = 1; only from points
    whose normal faces it.  (origins, directions, kept mask)."""
    o = points + OFFSET * normals
    d = np.broadcast_to(np.asarray(targets, np.float64), o.shape) - o
    lit = np.sum(normals * d, axis=1) > 0
    return np.ascontiguousarray(o[lit]), np.ascontiguousarray(d[lit]), lit


def area_light_points(light, n, rng):
    """n uniform points of the light's rectangle (centred on its position,
    facing its direction), as the renderer's light_size/frame define it."""
    from raytrace.renderer.driver import light_size
    a, b = light_size(light)
    w = np.asarray(light.direction, np.float64)
    w = w / np.linalg.norm(w)
    helper = np.array([1.0, 0, 0]) if abs(w[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(w, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(w, e1)
    uv = rng.uniform(-0.5, 0.5, size=(n, 2))
    return np.asarray(light.position, np.float64) + uv[:, :1] * a * e1 + uv[:, 1:] * b * e2


def cosine_rays(points, normals, rng):
    """From just off each point, unit directions cosine-distributed about
    its normal (Malley: uniform on the disc, lifted to the hemisphere)."""
    n = len(points)
    r = np.sqrt(rng.uniform(size=n))
    phi = 2 * np.pi * rng.uniform(size=n)
    x, y = r * np.cos(phi), r * np.sin(phi)
    z = np.sqrt(np.maximum(0.0, 1 - r * r))
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    e1 = np.cross(normals, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(normals, e1)
    d = x[:, None] * e1 + y[:, None] * e2 + z[:, None] * normals
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return points + OFFSET * normals, d


def teapot_mesh(detail):
    """(vertices float64, faces int64, camera, light) of the teapot alone."""
    import raytrace
    scene = raytrace.load_scene("teapot", detail=detail)
    mesh = scene.objects[0]
    return (np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64),
            scene.camera, scene.lights[0])


def ray_sets(v, f, camera, light, closest_prim_t, width, height, seed=SEED):
    """{name: (origins, directions, t_max)} for every set; closest_prim_t(o,
    d) -> (prim, t) gives the camera rays' hits."""
    rng = np.random.default_rng(seed)
    o, d = camera_rays(camera, width, height)
    so, sd, _ = shuffled((o, d), rng)
    bo, bd = box_rays(v.min(axis=0), v.max(axis=0), len(o), rng)
    prim, t = closest_prim_t(o, d)
    p, n = surface(v, f, o, d, prim, t)
    po, pd, _ = shadow_rays(p, n, light.position)
    ao, ad, _ = shadow_rays(p, n, area_light_points(light, len(p), rng))
    co, cd = cosine_rays(p, n, rng)
    inf = np.inf
    sets = {"camera": (o, d, inf), "shuffled": (so, sd, inf), "box": (bo, bd, inf),
            "shadow-point": (po, pd, 1.0), "shadow-area": (ao, ad, 1.0), "bounce": (co, cd, inf)}
    for name in ("camera", "box"):
        a, b, tm = sets[name]
        sets[name + " f32"] = (a.astype(np.float32), b.astype(np.float32), tm)
    return sets


def scene_and_sets(detail, width, height, threads=THREADS):
    """(RayScene of the teapot mesh with the BVH, the ray sets for it, its
    triangle count) on ``threads`` threads: bench/ray_costs.py's and
    bench/ray_sorting.py's start."""
    import numba

    from raytrace import RayScene
    numba.set_num_threads(threads)
    v, f, camera, light = teapot_mesh(detail)
    scene = RayScene((v, f))

    def closest(o, d):
        h = scene.cast_rays(o, d)
        return h.prim_id, h.t
    return scene, ray_sets(v, f, camera, light, closest, width, height), len(f)


# ---- the contestants: build(v32, f32) once, then query(scene, o, d, t_max) --

def _ours(v, f):
    from raytrace import RayScene
    scene = RayScene((v, f), accel="bvh")
    return {
        "closest": lambda o, d, tm: scene.cast_rays(o, d, t_max=tm).prim_id,
        "any": lambda o, d, tm: scene.occluded(o, d, t_max=tm),
        "count": lambda o, d, tm: scene.count_intersections(o, d, t_max=tm),
        "scene": scene,
    }


def _open3d(v, f):
    import open3d as o3d
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
    bad = scene.INVALID_ID

    def rays(o, d):
        return o3d.core.Tensor(np.hstack([o, d]))

    def closest(o, d, tm):
        ids = scene.cast_rays(rays(o, d), nthreads=THREADS)["primitive_ids"].numpy()
        return np.where(ids == bad, -1, ids.astype(np.int64))
    q = {"closest": closest,
         "any": lambda o, d, tm: scene.test_occlusions(rays(o, d), tfar=float(tm),
                                                       nthreads=THREADS).numpy().astype(bool),
         "count": lambda o, d, tm: scene.count_intersections(rays(o, d), nthreads=THREADS).numpy()}
    q["closest"](v[:1], v[:1], np.inf)   # Open3D builds its BVH at the first query
    return {"version": o3d.__version__, "threads": THREADS, "queries": q}


def _embreex(v, f):
    """Embree through embreex: EmbreeScene.run casts one ray at a time in
    a Cython loop; two Python threads take half the rays each."""
    import embreex
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, v, f)
    pool = ThreadPoolExecutor(THREADS)

    def split(fn, o, d, *rest):
        h = len(o) // 2
        parts = pool.map(lambda s: fn(o[s], d[s], *(r[s] for r in rest)),
                         (slice(0, h), slice(h, None)))
        return np.concatenate(list(parts))

    def any_hit(o, d, tm):
        dists = np.full(len(o), tm, np.float32)
        return split(lambda a, b, t: scene.run(a, b, query="OCCLUDED", dists=t) >= 0, o, d, dists)
    q = {"closest": lambda o, d, tm: split(lambda a, b: scene.run(a, b).astype(np.int64), o, d),
         "any": any_hit}
    q["closest"](v[:2], v[:2], np.inf)   # commits the scene
    return {"version": getattr(embreex, "__version__", "?"), "threads": THREADS, "queries": q}


def _mitsuba(v, f):
    """Mitsuba 3's llvm variant: scene.ray_intersect_preliminary and
    ray_test on Dr.Jit arrays made from the NumPy rays (timed)."""
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(THREADS)
    mesh = mi.Mesh("teapot", len(v), len(f))
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(v, np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(f, np.uint32).ravel())
    params.update()
    scene = mi.load_dict({"type": "scene", "teapot": mesh})

    def ray(o, d, tm):
        r = mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in o.T)),
                     mi.Vector3f(*(mi.Float(c) for c in d.T)))
        r.maxt = mi.Float(float(tm)) if np.isfinite(tm) else r.maxt
        return r

    def closest(o, d, tm):
        pi = scene.ray_intersect_preliminary(ray(o, d, tm))
        prim, ok = np.array(pi.prim_index), np.array(pi.is_valid())
        return np.where(ok, prim.astype(np.int64), -1)
    q = {"closest": closest, "any": lambda o, d, tm: np.array(scene.ray_test(ray(o, d, tm)))}
    q["closest"](v[:2].astype(np.float32), v[:2].astype(np.float32), np.inf)   # JIT, build
    return {"version": mi.__version__, "threads": THREADS, "queries": q}


PEERS = (("open3d", _open3d), ("embreex", _embreex), ("mitsuba", _mitsuba))


def peers(v32, f32):
    out = {}
    for name, make in PEERS:
        try:
            out[name] = make(v32, f32)
        except ImportError as e:
            log(f"workload: {name} does not import ({e}); no column")
    return out


def _agree(query, a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.mean(a == b)) if len(a) else float("nan")


def run_mesh(detail, runs, width, height):
    import numba
    numba.set_num_threads(THREADS)
    v, f, camera, light = teapot_mesh(detail)
    v32, f32 = np.ascontiguousarray(v, np.float32), np.ascontiguousarray(f, np.int32)
    log(f"workload: detail {detail}, {len(f):,} triangles; building")
    ours = _ours(v, f)

    def closest_prim_t(o, d):
        h = ours["scene"].cast_rays(o, d)
        return h.prim_id, h.t
    sets = ray_sets(v, f, camera, light, closest_prim_t, width, height)
    ours["closest"](*sets["camera"])    # load kernels and build the trees (count has its own)
    ours["count"](*sets["camera"])
    theirs = peers(v32, f32)
    rows = []
    for name, queries in ROWS:
        o, d, tm = sets[name]
        o32, d32 = o.astype(np.float32), d.astype(np.float32)
        for q in queries:
            tasks = {"ours": lambda q=q, o=o, d=d, tm=tm: ours[q](o, d, tm)}
            for p, pe in theirs.items():
                if q in pe["queries"]:
                    tasks[p] = lambda fn=pe["queries"][q], o=o32, d=d32, tm=tm: fn(o, d, tm)
            answers = {k: fn() for k, fn in tasks.items()}   # warm-up, and the answers compared
            times = {k: [] for k in tasks}
            for _ in range(runs):        # interleaved: ours, peer, peer', ours, ...
                for k, fn in tasks.items():
                    fn()    # untimed, as bench/peer.py: the last contestant's threads settle
                    t0 = time.perf_counter()
                    fn()
                    times[k].append(time.perf_counter() - t0)
            med = {k: median(ts) for k, ts in times.items()}
            row = {"set": name, "query": q, "rays": len(o), "ours_ms": med["ours"] * 1e3,
                   "times_s": times, "peers": {}}
            for p in theirs:
                if p in tasks:
                    row["peers"][p] = {"ms": med[p] * 1e3, "ratio": med[p] / med["ours"],
                                       "agree": _agree(q, answers["ours"], answers[p])}
            log(f"  {name:12s} {q:7s} ours {fmt_g(row['ours_ms'])} ms  "
                + "  ".join(f"{p} {fmt_g(e['ms'])} ms ({e['ratio']:.2f}x, {e['agree']:.3%})"
                            for p, e in row["peers"].items()))
            rows.append(row)
    return {"detail": detail, "triangles": int(len(f)), "rows": rows,
            "peers": {p: {"version": e["version"], "threads": e["threads"]} for p, e in theirs.items()}}


def run(quick):
    runs = 3 if quick else 7
    w, h = SIZE_QUICK if quick else SIZE_FULL
    meshes = [run_mesh(d, runs, w, h) for d in (DETAILS_QUICK if quick else DETAILS_FULL)]
    return {"runs": runs, "threads": THREADS, "width": w, "height": h, "seed": SEED,
            "meshes": meshes}


def markdown(res):
    names = []
    for m in res["meshes"]:
        names += [p for p in m["peers"] if p not in names]
    header = ["Triangles", "Rays", "Query", "Count", "Ours ms"]
    header += [f"{p} ms" for p in names] + [f"Ours / {p}" for p in names] + \
        [f"Same as {p}" for p in names]
    body = []
    for m in res["meshes"]:
        for r in m["rows"]:
            e = r["peers"]
            body.append([f"{m['triangles']:,}", r["set"], r["query"], f"{r['rays']:,}",
                         fmt_g(r["ours_ms"])]
                        + [fmt_g(e[p]["ms"]) if p in e else "-" for p in names]
                        + [f"{e[p]['ratio']:.2f}" if p in e else "-" for p in names]
                        + [f"{e[p]['agree']:.3%}" if p in e else "-" for p in names])
    versions = "; ".join(f"{p} {v['version']}" for p, v in res["meshes"][0]["peers"].items())
    out = ["### Workload suite (issue 40): the teapot mesh alone, RayScene against peers", "",
           markdown_table(header, body, align="rll" + "r" * (len(header) - 3)), "",
           (f"Rays: bench/workload.py's docstring ({res['width']}x{res['height']} camera rays, "
            f"seed {res['seed']}). Ours: RayScene (bvh) on float64 arrays (float32 for the f32 sets); "
            f"peers ({versions or 'none imported'}): float32 copies, made before timing. Each "
            f"scene built before timing. {res['threads']} threads for all (embreex: two Python "
            f"threads, half the rays each). Per row one warm-up call each, then {res['runs']} "
            f"interleaved rounds (ours, each peer, in turn), each timed call right after an "
            f"untimed one of its own (the last contestant's threads settle meanwhile); medians. "
            f"Ours / peer: the peer's time "
            f"over ours (> 1: we are faster). Same as: share of rays with the same answer (closest: "
            f"the same triangle or both miss; any: the same boolean; count: the same count); "
            f"float32 against float64 rounding moves a few grazing rays.")]
    return "\n".join(out)
