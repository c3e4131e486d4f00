"""Peer row: the same rays through our BVH and through Embree or Open3D.

Rays: the teapot camera's primary rays (one per pixel centre) and, from
each point they hit, one hard-shadow ray to the light (only where the
surface faces it, as the renderer does).  The target is the teapot mesh
plus the ground as a large quad (two triangles), since a peer has no
infinite plane.  Rays are made once in NumPy (float64); the peer gets
float32 copies, made before timing (Embree works in float32).

Our side: the renderer's batch kernels, which raytrace.cast_rays and
raytrace.occluded call.  Timed two ways: the kernel on a prebuilt BVH
(like the peer's query on its prebuilt scene) and the public call, which
flattens, validates and builds the BVH on every call.

Peers, whichever are importable (``pip install '.[peers]'`` for embreex):
- embreex (Embree 4 through Cython): EmbreeScene.run loops over rays on
  one thread, so we also give our single-thread figure;
- open3d (RaycastingScene, Embree inside, multi-threaded).
"""
import time

import numpy as np
from common import fmt_g, log, markdown_table, median

GROUND_HALF = 20.0    # the quad spans +-20 around the teapot (~3 units across); the
                      # view sees past it near the horizon, like any finite ground
SHADOW_OFFSET = 1e-4  # off the surface along the normal: ~200 float32 ulps here


def _embreex():
    try:
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        return None

    def build(v, f):
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, v, f)
        scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))  # commit
        return scene

    def closest(scene, o, d):
        return scene.run(o, d, output=1)["primID"]

    def occluded(scene, o, d, t_max):
        return scene.run(o, d, query="OCCLUDED", dists=t_max) >= 0

    import embreex
    return {"name": "embreex", "version": getattr(embreex, "__version__", "?"), "threads": 1,
            "build": build, "closest": closest, "occluded": occluded}


def _open3d():
    try:
        import open3d as o3d
    except ImportError:
        return None
    from numba import config

    def build(v, f):
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
        scene.cast_rays(o3d.core.Tensor(np.ones((1, 6), np.float32)))  # builds lazily
        return scene

    def closest(scene, o, d):
        ids = scene.cast_rays(o3d.core.Tensor(np.hstack([o, d])))["primitive_ids"].numpy()
        return np.where(ids == scene.INVALID_ID, -1, ids.astype(np.int64))

    def occluded(scene, o, d, t_max):
        rays = o3d.core.Tensor(np.hstack([o, d]))
        return scene.test_occlusions(rays, tfar=float(t_max[0])).numpy().astype(bool)

    return {"name": "open3d", "version": o3d.__version__, "threads": config.NUMBA_NUM_THREADS,
            "build": build, "closest": closest, "occluded": occluded}


def peers():
    return [p for p in (_embreex(), _open3d()) if p is not None]


def make_rays(detail, width, height):
    """(vertices, faces, primary (o, d), shadow (o, d, t_max)) in float64."""
    import raytrace
    from raytrace.renderer.driver import camera_buffer
    from raytrace.scene.builtin import teapot
    scene = teapot(detail)
    mesh = scene.objects[0]
    v = np.asarray(mesh.vertices, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    n = len(v)
    g = GROUND_HALF
    v = np.vstack([v, [[-g, 0, -g], [g, 0, -g], [g, 0, g], [-g, 0, g]]])
    f = np.vstack([f, [[n, n + 1, n + 2], [n, n + 2, n + 3]]])

    cam = camera_buffer(scene.camera, width, height)
    eye, fwd, right, up = cam[0:3], cam[3:6], cam[6:9], cam[9:12]
    fx = (np.arange(width) + 0.5) / width
    fy = (np.arange(height) + 0.5) / height
    sx, sy = np.meshgrid(2 * fx - 1, 1 - 2 * fy)
    d = fwd + sx.reshape(-1, 1) * right + sy.reshape(-1, 1) * up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(eye, d.shape).copy()

    hits = raytrace.cast_rays((v, f), o, d, accel="grid")  # any structure: the same hits
    hit = hits.hit
    p = o[hit] + hits.t[hit, None] * d[hit]
    tri = f[hits.prim_id[hit]]
    nrm = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm *= -np.sign(np.sum(nrm * d[hit], axis=1, keepdims=True))  # face the viewer
    light = np.asarray(scene.lights[0].position, np.float64)
    so = p + SHADOW_OFFSET * nrm
    sd = light - so
    lit = np.sum(nrm * sd, axis=1) > 0   # the renderer casts none from the dark side
    so, sd = so[lit], sd[lit]
    return v, f, (o, d), (so, sd, np.ones(len(so)))


def _time(fn, runs):
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def run_case(detail, width, height, runs, peer_list):
    import numba

    import raytrace
    from raytrace.accel.registry import build_structure
    from raytrace.cast.rays import _any_hit, _closest
    from raytrace.cast.rayscene import RayScene
    from raytrace.kernels.cast import ray_scene
    from raytrace.scene.flatten import flatten
    from raytrace.scene.model import Mesh, Scene

    # t_min made once, as t_max is: np.zeros inside the timed call maps its
    # pages lazily, and the kernel's threads then fault them in (1-2 ms).
    t_mins = {}

    def t_min(n):
        if n not in t_mins:
            t_mins[n] = np.full(n, 0.0)
        return t_mins[n]

    # Each (geo, acc)'s packed scene made once, as a RayScene keeps it (the
    # Packed holds geo and acc, so their ids are not reused meanwhile).
    scenes = {}

    def packed(geo, acc):
        key = (id(geo), id(acc))
        if key not in scenes:
            scenes[key] = ray_scene(geo, acc)
        return scenes[key]

    def closest(geo, acc, o, d, t_max):
        return _closest(packed(geo, acc), o, d, t_min(len(o)), t_max)

    def any_hit(geo, acc, o, d, t_max):
        return _any_hit(packed(geo, acc), o, d, t_min(len(o)), t_max)

    v, f, (po, pd), (so, sd, stm) = make_rays(detail, width, height)
    ptm = np.full(len(po), np.inf)
    log(f"peer: detail {detail}, {len(f):,} triangles, {len(po):,} primary and "
        f"{len(so):,} shadow rays")
    geo, obj_ranges, _, (_, face_of) = flatten(
        Scene(name="peer", camera=None, objects=[Mesh(v, f, name="t")]), with_sources=True)
    build_structure("bvh", geo, obj_ranges)  # loads the compiled builders from Numba's cache
    t0 = time.perf_counter()
    acc, _ = build_structure("bvh", geo, obj_ranges)
    ours_first_build = time.perf_counter() - t0
    threads = numba.get_num_threads()
    scene = RayScene((v, f), accel="bvh")   # the public API, built once
    scene.cast_rays(po[:1], pd[:1])

    def single(fn):
        def go():
            numba.set_num_threads(1)
            try:
                fn()
            finally:
                numba.set_num_threads(threads)
        return go

    ours = {
        ("primary", "kernel"): lambda: closest(geo, acc, po, pd, ptm),
        ("primary", "kernel_1t"): single(lambda: closest(geo, acc, po, pd, ptm)),
        ("primary", "scene"): lambda: scene.cast_rays(po, pd),
        ("primary", "api"): lambda: raytrace.cast_rays((v, f), po, pd, accel="bvh"),
        ("shadow", "kernel"): lambda: any_hit(geo, acc, so, sd, stm),
        ("shadow", "kernel_1t"): single(lambda: any_hit(geo, acc, so, sd, stm)),
        ("shadow", "scene"): lambda: scene.occluded(so, sd, t_max=stm),
        ("shadow", "api"): lambda: raytrace.occluded((v, f), so, sd, stm, accel="bvh"),
        # Builds alone, timed in the rounds too: one build's time moves by
        # 5-10% from run to run here, as much as ours and a peer's differ.
        ("build", "ours"): lambda: build_structure("bvh", geo, obj_ranges),
    }
    v32, f32 = np.ascontiguousarray(v, np.float32), np.ascontiguousarray(f, np.int32)
    rays32 = {k: tuple(np.ascontiguousarray(a, np.float32) for a in arrs)
              for k, arrs in (("primary", (po, pd)), ("shadow", (so, sd, stm)))}
    tasks = dict(ours)
    peer_scenes = {}
    for p in peer_list:
        t0 = time.perf_counter()
        sc = p["build"](v32, f32)
        peer_scenes[p["name"]] = (sc, time.perf_counter() - t0)
        o32, d32 = rays32["primary"]
        so32, sd32, st32 = rays32["shadow"]
        tasks[("primary", p["name"])] = (lambda p=p, sc=sc, o=o32, d=d32: p["closest"](sc, o, d))
        tasks[("shadow", p["name"])] = (lambda p=p, sc=sc, o=so32, d=sd32, t=st32:
                                        p["occluded"](sc, o, d, t))
        # Built again inside the timed call, to set against our public call.
        tasks[("primary", p["name"] + "+build")] = (
            lambda p=p, o=o32, d=d32: p["closest"](p["build"](v32, f32), o, d))
        tasks[("build", p["name"])] = lambda p=p: p["build"](v32, f32)

    for fn in tasks.values():   # warm-up: compile or load kernels, start threads
        fn()
    times = {k: [] for k in tasks}
    for _ in range(runs):       # interleaved rounds
        for k, fn in tasks.items():
            fn()                # untimed: the previous task's threads settle
            times[k] += _time(fn, 2)
    med = {k: median(ts) for k, ts in times.items()}
    n_rays = {"primary": len(po), "shadow": len(so)}

    # Agreement: the same answers, up to float32 vs float64 rounding.
    ours_prim = closest(geo, acc, po, pd, ptm)[0][1]
    ours_prim = np.where(ours_prim >= 0, face_of[np.maximum(ours_prim, 0)], -1)  # face rows
    ours_occ = any_hit(geo, acc, so, sd, stm)[0]
    result = {"detail": detail, "triangles": int(len(f)), "width": width, "height": height,
              "rays": n_rays, "runs": runs, "threads": threads, "ours_build_s": med[("build", "ours")],
              "ours_first_build_s": ours_first_build,
              "ours": {}, "peers": {}}
    for kind in ("primary", "shadow"):
        result["ours"][kind] = {m: {"s": med[(kind, m)], "times_s": times[(kind, m)],
                                    "mrays_per_s": n_rays[kind] / med[(kind, m)] / 1e6}
                                for m in ("kernel", "kernel_1t", "scene", "api")}
    for p in peer_list:
        sc, first_build_s = peer_scenes[p["name"]]
        o32, d32 = rays32["primary"]
        so32, sd32, st32 = rays32["shadow"]
        prim = np.asarray(p["closest"](sc, o32, d32)).astype(np.int64)
        occ = np.asarray(p["occluded"](sc, so32, sd32, st32))
        entry = {"version": p["version"], "threads": p["threads"], "build_s": med[("build", p["name"])],
                 "first_build_s": first_build_s,
                 "agree_hit": float(np.mean((prim >= 0) == (ours_prim >= 0))),
                 "agree_prim": float(np.mean(prim == ours_prim)),
                 "agree_occluded": float(np.mean(occ == ours_occ))}
        for kind in ("primary", "shadow"):
            s = med[(kind, p["name"])]
            e = {"s": s, "times_s": times[(kind, p["name"])], "mrays_per_s": n_rays[kind] / s / 1e6}
            for m in ("kernel", "kernel_1t", "scene", "api"):
                e["ratio_ours_" + m] = result["ours"][kind][m]["mrays_per_s"] / e["mrays_per_s"]
            entry[kind] = e
        s = med[("primary", p["name"] + "+build")]
        entry["primary_with_build"] = {
            "s": s, "mrays_per_s": n_rays["primary"] / s / 1e6,
            "ratio_ours_api": (n_rays["primary"] / med[("primary", "api")]) / (n_rays["primary"] / s)}
        result["peers"][p["name"]] = entry
    result["small_calls"] = small_calls(scene, {p["name"]: (p, peer_scenes[p["name"]][0])
                                                for p in peer_list},
                                        (po, pd), (so, sd, stm))
    return result


SMALL_CALLS = (1, 1_024)    # rays a call: one, and one chunk (kernels/cast.py: one thread)


def small_calls(scene, peer_scenes, primary, shadow, calls=200):
    """Microseconds a call of a few rays (medians of ``calls`` calls, ours
    and each peer's alternated a call at a time): what a user pays who casts
    small batches, where a call's fixed costs (validation, thread start,
    results) outweigh its rays."""
    out = {}
    for n in SMALL_CALLS:
        o, d = (np.ascontiguousarray(a[:n]) for a in primary)
        so, sd, st = (np.ascontiguousarray(a[:n]) for a in shadow)
        tasks = {("ours", "primary"): lambda o=o, d=d: scene.cast_rays(o, d),
                 ("ours", "shadow"): lambda so=so, sd=sd, st=st: scene.occluded(so, sd, t_max=st)}
        for name, (p, sc) in peer_scenes.items():
            o32, d32, so32, sd32, st32 = (a.astype(np.float32) for a in (o, d, so, sd, st))
            tasks[(name, "primary")] = (lambda p=p, sc=sc, o=o32, d=d32: p["closest"](sc, o, d))
            tasks[(name, "shadow")] = (lambda p=p, sc=sc, o=so32, d=sd32, t=st32:
                                       p["occluded"](sc, o, d, t))
        times = {k: [] for k in tasks}
        for fn in tasks.values():
            fn()
        for _ in range(calls):
            for k, fn in tasks.items():
                times[k] += _time(fn, 1)
        out[n] = {f"{who} {kind}": median(ts) * 1e6 for (who, kind), ts in times.items()}
    return out


def _read(fields, names):
    return {k: fields[k] for k in names}


def run_queries(quick, runs):
    """count_intersections, list_intersections, contains, distance and
    signed_distance against Open3D's count_intersections,
    list_intersections, compute_occupancy, compute_distance and
    compute_signed_distance, on a closed mesh (a bumpy icosphere: Open3D's
    occupancy and sign come from ray parity, which needs one) with random
    points in its box and random rays through it."""
    try:
        import open3d as o3d
        import trimesh
    except ImportError:
        return None
    from raytrace import RayScene
    rng = np.random.default_rng(0)
    m = trimesh.creation.icosphere(subdivisions=3 if quick else 5)
    v = m.vertices * rng.uniform(0.8, 1.2, (len(m.vertices), 1))
    f = np.asarray(m.faces, np.int64)
    n = 20_000 if quick else 200_000
    pts = rng.uniform(-1.3, 1.3, (n, 3))
    ro = rng.uniform(-1.3, 1.3, (n, 3))
    rd = rng.normal(size=(n, 3))
    ours = RayScene((v, f))
    theirs = o3d.t.geometry.RaycastingScene()
    theirs.add_triangles(o3d.core.Tensor(v.astype(np.float32)),
                         o3d.core.Tensor(f.astype(np.uint32)))
    p32 = o3d.core.Tensor(pts.astype(np.float32))
    r32 = o3d.core.Tensor(np.hstack([ro, rd]).astype(np.float32))
    tasks = {
        "count_intersections": (lambda: ours.count_intersections(ro, rd),
                                lambda: theirs.count_intersections(r32).numpy()),
        # Ours reads the fields Open3D returns (a HitList makes ids and
        # barycentrics when first read).
        "list_intersections": (
            lambda: _read(ours.list_intersections(ro, rd), ("ray_splits", "t", "geometry_id",
                                                            "prim_id", "u", "v")),
            lambda: {k: a.numpy() for k, a in theirs.list_intersections(r32).items()}),
        "contains / compute_occupancy": (lambda: ours.contains(pts),
                                         lambda: theirs.compute_occupancy(p32).numpy()),
        "distance / compute_distance": (lambda: ours.distance(pts),
                                        lambda: theirs.compute_distance(p32).numpy()),
        "signed_distance / compute_signed_distance": (
            lambda: ours.signed_distance(pts), lambda: theirs.compute_signed_distance(p32).numpy()),
    }
    out = {"triangles": len(f), "count": n, "open3d": o3d.__version__, "rows": {}}
    for name, (a, b) in tasks.items():
        ra, rb = a(), b()   # warm-up: compile, build
        ta, tb = [], []
        for _ in range(runs):   # as run_case: a settling call, then two timed
            a()
            ta += _time(a, 2)
            b()
            tb += _time(b, 2)
        if name.startswith("count"):
            agree = np.mean(ra == rb)
        elif name.startswith("list"):     # rays with as many hits
            agree = np.mean(np.diff(ra["ray_splits"]) == np.diff(rb["ray_splits"]))
        elif name.startswith("contains"):
            agree = np.mean(ra == (rb > 0.5))
        elif name.startswith("distance"):
            agree = np.mean(np.abs(ra - rb) <= 1e-5 * np.maximum(1.0, ra))
        else:
            agree = np.mean((np.sign(ra) == np.sign(rb)) & (np.abs(np.abs(ra) - np.abs(rb)) <= 1e-5))
        out["rows"][name] = {"ours_s": median(ta), "peer_s": median(tb),
                             "ratio": median(tb) / median(ta), "agree": float(agree)}
    k = 2_000 if quick else 20_000
    out["trimesh"] = {"version": trimesh.__version__, "sample": k,
                      "rows": trimesh_agreement(ours, trimesh.Trimesh(v, f, process=False),
                                                pts[:k], ro[:k], rd[:k])}
    return out


def trimesh_agreement(ours, mesh, pts, ro, rd):
    """Per query, the share of these points or rays on which ours and
    trimesh agree, and where they differ.  trimesh: float64 geometry; its
    rays go through embreex when that is installed (the peers extra), each
    further hit by a new ray from just past the last; its distances come
    from faces near the nearest vertices, its sign from its own ray
    parity, positive inside (ours: positive outside).  Its distances need
    SciPy, which the peers extra leaves out: with SciPy installed, Numba
    imports SciPy's BLAS when it first loads a kernel (0.19 s and 20 MB
    more for every raytrace command, our start-up figures included).
    Without it, the distance rows say they need it."""
    import trimesh
    _, ray_of, _ = mesh.ray.intersects_location(ro, rd, multiple_hits=True)
    crossings = np.bincount(ray_of, minlength=len(ro))
    same = {
        "count_intersections": ours.count_intersections(ro, rd) == crossings,
        "list_intersections": np.diff(ours.list_intersections(ro, rd).ray_splits) == crossings,
        "contains / compute_occupancy": ours.contains(pts) == mesh.contains(pts),
    }
    distances = ("distance / compute_distance", "signed_distance / compute_signed_distance")
    try:
        import scipy  # noqa: F401
    except ImportError:
        log("peer: scipy is not installed: no trimesh distances (pip install scipy)")
        same.update((name, None) for name in distances)
    else:
        theirs = -trimesh.proximity.signed_distance(mesh, pts)
        ours_sd = ours.signed_distance(pts)
        tol = 1e-9 * np.maximum(1.0, np.abs(theirs))
        same[distances[0]] = np.abs(ours.distance(pts) - np.abs(theirs)) <= tol
        same[distances[1]] = ((np.sign(ours_sd) == np.sign(theirs))
                              & (np.abs(np.abs(ours_sd) - np.abs(theirs)) <= tol))
    return {name: ({"agree": None, "differ": []} if ok is None else
                   {"agree": float(np.mean(ok)), "differ": np.flatnonzero(~ok).tolist()})
            for name, ok in same.items()}


def run(quick):
    plist = peers()
    if not plist:
        log("peer: neither embreex nor open3d is importable; skipped")
        return {"skipped": "neither embreex nor open3d is importable "
                           "(pip install '.[peers]' installs embreex)"}
    w, h = (160, 120) if quick else (640, 480)
    details = (4,) if quick else (4, 43)
    runs = 5 if quick else 7
    return {"peers": [p["name"] for p in plist],
            "cases": [run_case(d, w, h, runs, plist) for d in details],
            "queries": run_queries(quick, runs)}


def _differ(row):
    """A query's agreement with trimesh, as a table cell."""
    if row is None:
        return ""
    return "needs SciPy" if row["agree"] is None else f"{row['agree']:.4%}"


def markdown(res):
    out = ["### Peer: the same rays through our BVH and a peer", ""]
    if "skipped" in res:
        return "\n".join(out + [f"Skipped: {res['skipped']}."])
    header = ["Triangles", "Rays", "Count", "Ours Mrays/s", "Ours 1 thread", "RayScene Mrays/s",
              "Peer", "Peer Mrays/s", "Ours / peer", "Ours 1 thread / peer", "RayScene / peer",
              "Agreement"]
    body = []
    for case in res["cases"]:
        for name, e in case["peers"].items():
            for kind in ("primary", "shadow"):
                o = case["ours"][kind]
                agree = (f"{e['agree_prim']:.4%} same triangle" if kind == "primary"
                         else f"{e['agree_occluded']:.4%} same answer")
                body.append([f"{case['triangles']:,}", kind, f"{case['rays'][kind]:,}",
                             fmt_g(o["kernel"]["mrays_per_s"]), fmt_g(o["kernel_1t"]["mrays_per_s"]),
                             fmt_g(o["scene"]["mrays_per_s"]),
                             f"{name} {e['version']} ({e['threads']} thr)",
                             fmt_g(e[kind]["mrays_per_s"]), f"{e[kind]['ratio_ours_kernel']:.2f}",
                             f"{e[kind]['ratio_ours_kernel_1t']:.2f}",
                             f"{e[kind]['ratio_ours_scene']:.2f}", agree])
    out.append(markdown_table(header, body, align="rlr" + "r" * 3 + "l" + "r" * 4 + "l"))
    case0 = res["cases"][0]
    out += ["", (f"{case0['width']}x{case0['height']} camera rays at pixel centres and one hard-shadow "
                 f"ray per lit hit, the teapot plus a ground quad. Ours: the batch kernels behind "
                 f"`raytrace.cast_rays` / `raytrace.occluded` on a prebuilt BVH, float64, "
                 f"{case0['threads']} threads (and pinned to 1); RayScene: the public "
                 f"`RayScene.cast_rays` / `.occluded` on a scene built once (validation and "
                 f"results included); the peer: float32 copies of the "
                 f"same rays on its prebuilt scene. In {case0['runs']} rounds each task runs "
                 f"three times in a row, the last two timed (so the previous task's threads "
                 f"have settled, whoever's they were); medians. Ratio > 1: we are faster.")]
    lines = []
    for case in res["cases"]:
        for kind in ("primary", "shadow"):
            o = case["ours"][kind]
            lines.append(f"- {case['triangles']:,} triangles, {kind} rays: a RayScene call costs "
                         f"{o['scene']['s'] / o['kernel']['s'] - 1:+.1%} over its kernel "
                         f"({fmt_g(o['scene']['s'] * 1e3)} ms against {fmt_g(o['kernel']['s'] * 1e3)} ms).")
        for name, e in case["peers"].items():
            api = case["ours"]["primary"]["api"]
            lines.append(f"- {case['triangles']:,} triangles, whole calls including the build: "
                         f"`raytrace.cast_rays` {fmt_g(api['s'] * 1e3)} ms, {name} build + query "
                         f"{fmt_g(e['primary_with_build']['s'] * 1e3)} ms (ours / peer "
                         f"{e['primary_with_build']['ratio_ours_api']:.2f} in rays/s); builds alone: "
                         f"ours {fmt_g(case['ours_build_s'] * 1e3)} ms, {name} "
                         f"{fmt_g(e['build_s'] * 1e3)} ms (medians of the rounds; one build "
                         f"each before them: ours {fmt_g(case['ours_first_build_s'] * 1e3)} ms, {name} "
                         f"{fmt_g(e['first_build_s'] * 1e3)} ms).")
    for case in res["cases"]:
        for n, us in case.get("small_calls", {}).items():
            peers_us = "; ".join(f"{name} {fmt_g(us[name + ' primary'])} and "
                                 f"{fmt_g(us[name + ' shadow'])} us" for name in case["peers"])
            lines.append(f"- {case['triangles']:,} triangles, calls of {int(n):,} "
                         f"ray{'s' if int(n) > 1 else ''} (medians of 200, alternated): "
                         f"RayScene.cast_rays {fmt_g(us['ours primary'])} us, .occluded "
                         f"{fmt_g(us['ours shadow'])} us; {peers_us}.")
    q = res.get("queries")
    if q:
        lines += ["", f"Queries on a closed mesh ({q['triangles']:,} triangles, a bumpy icosphere), "
                      f"{q['count']:,} random points or rays in its box, against Open3D "
                      f"{q['open3d']} (float32), {case0['runs']} rounds timed as above:", ""]
        tm = q.get("trimesh", {"rows": {}, "sample": 0})
        body = [[name, fmt_g(r["ours_s"] * 1e3), fmt_g(r["peer_s"] * 1e3), f"{r['ratio']:.2f}",
                 f"{r['agree']:.4%}", _differ(tm["rows"].get(name))]
                for name, r in q["rows"].items()]
        lines.append(markdown_table(["Query (ours / Open3D)", "Ours ms", "Open3D ms",
                                     "Ours / peer (speed)", "Same answer",
                                     f"Same answer as trimesh (first {tm['sample']:,})"],
                                    body, align="lrrrrr"))
        if tm["rows"]:
            differ = "; ".join(f"{name}: {r['differ'][:5]}"
                               for name, r in tm["rows"].items() if r["differ"])
            lines += ["", f"trimesh {tm['version']} (float64; its rays through embreex, each "
                          "further hit cast again from just past the last; distances to faces "
                          "near the nearest vertices). "
                          + (f"Where it differs, the first indices: {differ}." if differ
                             else "Wherever compared, it gives our answer.")]
    return "\n".join(out + [""] + lines)
