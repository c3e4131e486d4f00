"""The Cornell box path-traced by raytrace and by Mitsuba 3, side by side
in one run: agreement and time to a given error.

The same triangles (written as PLY files for Mitsuba), camera (39.3
degrees vertical), box pixel filter, diffuse reflectances and emitter;
Mitsuba's `path` integrator with max_depth = raytrace's --max-depth + 1
(Mitsuba counts the camera ray's hit as depth 1) and its independent
sampler.  Both render seeds A and B at SPP samples:

- agreement: each renderer's mean image value (A and B averaged), their
  ratio; and per block of BLOCK x BLOCK pixels and channel, the difference
  of the block means in standard errors, each block's error estimated
  from the two seeds' per-pixel differences ((a - b)^2 / 2 is a pixel's
  variance at SPP samples);
- time to an RMSE: both renderers at spp 4 and 16 (other seeds), RMSE
  against the reference, the mean of the four SPP-sample images, less
  that reference's own noise (in quadrature); fitted as RMSE = c t^-1/2
  through the two, each renderer's time to reach TARGET RMSE.  Times are
  warm wall seconds of a whole render call (Mitsuba's first call at an spp,
  which compiles its kernel, is run and not timed).

Needs Mitsuba 3 (the `peers` extra; it is installed in the suite's venv).
Its llvm variant's path integrator needs a newer LLVM than Debian 12's
default 14 or 15 ("LLVM ERROR: Cannot select: ... fminimum"): with
`apt-get install libllvm19` this script points DRJIT_LIBLLVM_PATH at the
newest libLLVM it finds, unless it is set.

    PYTHONPATH=. /work/wt-suite/.venv/bin/python bench/mitsuba_cornell.py [--size 512] [--spp 64]
"""
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import click
import numpy as np

BLOCK = 32
SEEDS = (1, 2)
LOW_SPP = (4, 16)
LOW_SEEDS = (11, 12)


def write_ply(path, vertices, faces):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}",
             "property float x", "property float y", "property float z",
             f"element face {len(faces)}", "property list uchar int vertex_indices",
             "end_header"]
    lines += [" ".join(f"{c:.9g}" for c in v) for v in vertices]
    lines += ["3 " + " ".join(str(int(i)) for i in f) for f in faces]
    Path(path).write_text("\n".join(lines) + "\n")


def mitsuba_scene(scene, size, max_depth, folder):
    """Mitsuba's scene dict for raytrace's (meshes of diffuse materials,
    emission as area emitters)."""
    import mitsuba as mi
    cam = scene.camera
    try:
        to_world = mi.ScalarTransform4f().look_at(origin=cam.eye, target=cam.look_at, up=cam.up)
    except TypeError:
        to_world = mi.ScalarTransform4f.look_at(origin=cam.eye, target=cam.look_at, up=cam.up)
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth + 1},
         "sensor": {"type": "perspective", "fov": cam.fov, "fov_axis": "y", "to_world": to_world,
                    "film": {"type": "hdrfilm", "width": size, "height": size,
                             "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": 4}}}
    for k, o in enumerate(scene.objects):
        m = o.material
        path = Path(folder) / f"object{k}.ply"
        write_ply(path, np.asarray(o.vertices), np.asarray(o.faces))
        obj = {"type": "ply", "filename": str(path), "face_normals": True,
               "bsdf": {"type": "diffuse", "reflectance": {
                   "type": "rgb", "value": [m.diffuse * c for c in m.color]}}}
        if max(m.emission) > 0:
            obj["emitter"] = {"type": "area", "radiance": {"type": "rgb",
                                                            "value": list(m.emission)}}
        d[f"object{k}"] = obj
    return mi.load_dict(d)


def newest_llvm():
    """Point Dr.Jit at the newest system libLLVM, unless told another."""
    import glob
    import os
    import re
    found = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM*.so*") + glob.glob(
        "/usr/lib/llvm-*/lib/libLLVM*.so*"), key=lambda p: [int(x) for x in re.findall(
            r"\d+", Path(p).name)] or [0])
    if found and "DRJIT_LIBLLVM_PATH" not in os.environ:
        os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]


def run(size, spp, variant, max_depth=16):
    newest_llvm()
    import mitsuba as mi
    mi.set_variant(variant)
    import raytrace
    scene = raytrace.load_scene("cornell", width=size, height=size)
    log = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    raytrace.render(scene, spp=1, width=8, height=8)                  # compile or load
    with tempfile.TemporaryDirectory() as folder:
        ms = mitsuba_scene(scene, size, max_depth, folder)

        def mitsuba(n, seed):
            t = time.perf_counter()
            img = np.array(mi.render(ms, spp=n, seed=seed), dtype=np.float64)
            return img, time.perf_counter() - t

        def ours(n, seed):
            t = time.perf_counter()
            img = raytrace.render(scene, spp=n, seed=seed, max_depth=max_depth).linear
            return img.astype(np.float64), time.perf_counter() - t
        for n in (*LOW_SPP, spp):
            mitsuba(n, 99)                                             # Mitsuba's kernel compile
        hi = {}
        for seed in SEEDS:      # interleaved
            for name, fn in (("raytrace", ours), ("mitsuba", mitsuba)):
                hi[name, seed] = fn(spp, seed)
                log(f"{name} {spp} spp seed {seed}: {hi[name, seed][1]:.1f} s")
        low = {}
        for n in LOW_SPP:
            for seed in LOW_SEEDS:
                for name, fn in (("raytrace", ours), ("mitsuba", mitsuba)):
                    low[name, n, seed] = fn(n, seed)
    res = {"size": size, "spp": spp, "variant": variant, "mitsuba_version": mi.__version__,
           "max_depth": max_depth, "block": BLOCK}
    ref = np.mean([hi[k][0] for k in hi], axis=0)
    var = {}
    for name in ("raytrace", "mitsuba"):
        a, b = hi[name, SEEDS[0]][0], hi[name, SEEDS[1]][0]
        var[name] = (a - b) ** 2 / 2          # a pixel's variance at spp samples
        res[name] = {"mean": float((a + b).mean() / 2), "seconds": [hi[name, s][1] for s in SEEDS],
                     "channel_means": ((a + b) / 2).mean(axis=(0, 1)).tolist()}
    res["mean_ratio"] = res["raytrace"]["mean"] / res["mitsuba"]["mean"]
    # Per block: difference of the two seeds' mean, in standard errors.
    nb = size // BLOCK

    def blocks(x):
        return x[:nb * BLOCK, :nb * BLOCK].reshape(nb, BLOCK, nb, BLOCK, 3).mean(axis=(1, 3))
    mean_rt = blocks((hi["raytrace", SEEDS[0]][0] + hi["raytrace", SEEDS[1]][0]) / 2)
    mean_mi = blocks((hi["mitsuba", SEEDS[0]][0] + hi["mitsuba", SEEDS[1]][0]) / 2)
    # Var of a block mean of two seeds: the pixels' mean variance / (pixels x 2).
    se = np.sqrt((blocks(var["raytrace"]) + blocks(var["mitsuba"])) / (BLOCK * BLOCK * 2))
    z = (mean_rt - mean_mi) / np.where(se > 0, se, np.inf)
    res["blocks"] = {"count": int(z.size), "within_3_se": float(np.mean(np.abs(z) <= 3)),
                     "max_abs_z": float(np.abs(z).max()), "mean_z2": float(np.mean(z * z))}
    # Time to an RMSE against the reference, less the reference's own noise.
    ref_noise2 = float(np.mean((var["raytrace"] + var["mitsuba"]) / 2) / len(hi))
    res["reference_noise_rmse"] = math.sqrt(ref_noise2)
    curves = {}
    for name in ("raytrace", "mitsuba"):
        pts = []
        for n in LOW_SPP:
            e2 = [np.mean((low[name, n, s][0] - ref) ** 2) for s in LOW_SEEDS]
            t = float(np.median([low[name, n, s][1] for s in LOW_SEEDS]))
            pts.append({"spp": n, "seconds": t,
                        "rmse": math.sqrt(max(float(np.mean(e2)) - ref_noise2, 0.0))})
        # RMSE = c t^-1/2: c from the points' geometric mean.
        c = math.exp(np.mean([math.log(p["rmse"]) + 0.5 * math.log(p["seconds"]) for p in pts]))
        curves[name] = {"points": pts, "c": c}
    target = curves["raytrace"]["points"][-1]["rmse"]
    for name in curves:
        curves[name]["seconds_to_target"] = (curves[name]["c"] / target) ** 2
    res["time_to_rmse"] = {"target_rmse": target, "curves": curves,
                           "ratio_raytrace_over_mitsuba":
                               curves["raytrace"]["seconds_to_target"]
                               / curves["mitsuba"]["seconds_to_target"]}
    return res, hi


def side_by_side(hi, path):
    """raytrace | Mitsuba, seed A each, sRGB PNG."""
    from raytrace.renderer.driver import to_srgb8
    from raytrace.renderer.output import write_png
    img = np.concatenate([hi["raytrace", SEEDS[0]][0], np.zeros((hi["raytrace", SEEDS[0]][0]
                                                                   .shape[0], 8, 3)),
                          hi["mitsuba", SEEDS[0]][0]], axis=1).astype(np.float32)
    write_png(path, to_srgb8(img))


def markdown(res):
    rt, mi_ = res["raytrace"], res["mitsuba"]
    b, tt = res["blocks"], res["time_to_rmse"]
    lines = [f"### Cornell box {res['size']}x{res['size']}: raytrace against Mitsuba "
             f"{res['mitsuba_version']} ({res['variant']}), {res['spp']} spp, max depth {res['max_depth']}",
             "",
             "| | raytrace | Mitsuba |", "| --- | ---: | ---: |",
             f"| mean linear value | {rt['mean']:.5f} | {mi_['mean']:.5f} |",
             f"| R, G, B means | {', '.join(f'{x:.4f}' for x in rt['channel_means'])} | "
             f"{', '.join(f'{x:.4f}' for x in mi_['channel_means'])} |",
             f"| seconds at {res['spp']} spp (two seeds) | "
             f"{', '.join(f'{x:.1f}' for x in rt['seconds'])} | "
             f"{', '.join(f'{x:.1f}' for x in mi_['seconds'])} |"]
    for k, p in enumerate(tt["curves"]["raytrace"]["points"]):
        q = tt["curves"]["mitsuba"]["points"][k]
        lines.append(f"| RMSE, seconds at {p['spp']} spp | {p['rmse']:.4f}, {p['seconds']:.2f} | "
                     f"{q['rmse']:.4f}, {q['seconds']:.2f} |")
    lines.append(f"| seconds to RMSE {tt['target_rmse']:.4f} | "
                 f"{tt['curves']['raytrace']['seconds_to_target']:.2f} | "
                 f"{tt['curves']['mitsuba']['seconds_to_target']:.2f} |")
    lines += ["", f"Mean ratio raytrace / Mitsuba: {res['mean_ratio']:.4f}. Blocks of "
              f"{res['block']}x{res['block']} pixels x 3 channels: {b['count']}, "
              f"{100 * b['within_3_se']:.1f}% within 3 standard errors, largest |z| "
              f"{b['max_abs_z']:.2f}, mean z^2 {b['mean_z2']:.2f} (1 if they differ by noise "
              f"alone). Time to the RMSE: raytrace / Mitsuba = "
              f"{tt['ratio_raytrace_over_mitsuba']:.2f}. Reference's own noise "
              f"{res['reference_noise_rmse']:.4f} RMSE, subtracted."]
    return "\n".join(lines)


@click.command()
@click.option("--size", default=512, show_default=True)
@click.option("--spp", default=64, show_default=True, help="the agreement renders' samples")
@click.option("--variant", default="llvm_ad_rgb", show_default=True)
@click.option("--png", type=click.Path(dir_okay=False), default="bench-out/cornell_mitsuba.png",
              show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(size, spp, variant, png, json_path):
    """raytrace's and Mitsuba 3's Cornell box: agreement and time to an RMSE."""
    res, hi = run(size, spp, variant)
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    side_by_side(hi, png)
    res["png"] = png
    print(markdown(res))
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    main()
