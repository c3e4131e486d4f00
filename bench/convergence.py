"""Soft shadows: Monte Carlo error against run time, per sampling pattern.

For N = 1, 4, 16, 64, 256 light samples and each pattern (grid, random,
stratified, halton), render the teapot with soft shadows and compare the
linear float image with a reference of 4,096 stratified samples (another
seed, so its noise is independent of every test image's):

    RMSE = sqrt(mean over pixels and channels of (image - reference)^2)
    PSNR = 20 log10(1 / RMSE)   (peak 1: a fully lit white surface)

The convergence rate of a pattern is the least-squares slope of log RMSE
against log N: -0.5 is plain Monte Carlo, steeper is better.  N = 1 is the
light's centre for every pattern (the renderer's rule for one sample: a
hard shadow), so a second slope leaves it out.  The reference has noise of
its own, estimated from a second reference with a third seed
(RMSE between the two / sqrt 2); errors near it flatten the slope.

    python bench/convergence.py [--quick] [--plot FILE] [--json FILE]
"""
import json
import math
import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402
from common import fmt_g, fmt_s, interleaved, log, markdown_table, median  # noqa: E402

PATTERNS = ("grid", "random", "stratified", "halton")
SAMPLES = (1, 4, 16, 64, 256)      # squares, as grid and stratified need
REFERENCE_SAMPLES = 4096
SEED, REFERENCE_SEEDS = 0, (1, 2)
FULL = dict(width=160, height=120, budget_s=3.0, max_runs=5)
QUICK = dict(width=80, height=60, budget_s=0.5, max_runs=3)


def run(quick, plot_path=None):
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    cfg = QUICK if quick else FULL
    w, h = cfg["width"], cfg["height"]
    accel = "bvh"   # the fastest here; every structure gives the same image
    scene = teapot(4)
    soft = dict(accel=accel, shadows="soft", width=w, height=h)
    log(f"convergence: {w}x{h}, accel {accel}, references of {REFERENCE_SAMPLES} samples")
    refs = [render(scene, light_samples=REFERENCE_SAMPLES, pattern="stratified", seed=s, **soft)
            for s in REFERENCE_SEEDS]
    ref = refs[0].linear
    ref_noise = common.rmse(refs[0].linear, refs[1].linear) / math.sqrt(2)

    cells = [(p, n) for n in SAMPLES for p in PATTERNS]
    for p in PATTERNS:   # warm-up (the kernel is shared, so this is brief)
        render(scene, light_samples=4, pattern=p, seed=SEED, **soft)

    def once(cell):
        p, n = cell
        r = render(scene, light_samples=n, pattern=p, seed=SEED, **soft)
        return common.render_time(r), r
    times, first = interleaved(cells, once, cfg["budget_s"], cfg["max_runs"])
    rows = []
    for p, n in cells:
        err = common.rmse(first[(p, n)].linear, ref)
        rows.append({"pattern": p, "samples": n, "render_s": median(times[(p, n)]),
                     "runs": len(times[(p, n)]), "times_s": times[(p, n)],
                     "rays": first[(p, n)].stats["derived"]["rays"],
                     "rmse": err, "psnr_db": common.psnr(err)})
    slopes = {}
    for p in PATTERNS:
        pr = [r for r in rows if r["pattern"] == p]
        slopes[p] = {
            "all": common.loglog_slope([r["samples"] for r in pr], [r["rmse"] for r in pr]),
            "from_4": common.loglog_slope([r["samples"] for r in pr if r["samples"] > 1],
                                          [r["rmse"] for r in pr if r["samples"] > 1]),
        }
    res = {"width": w, "height": h, "accel": accel, "scene": "teapot", "detail": 4,
           "seed": SEED, "reference": {"samples": REFERENCE_SAMPLES, "pattern": "stratified",
                                       "seeds": list(REFERENCE_SEEDS),
                                       "render_s": refs[0].stats["time"]["render_s"],
                                       "noise_rmse": ref_noise},
           "budget_s": cfg["budget_s"], "max_runs": cfg["max_runs"], "rows": rows, "slopes": slopes}
    res["plot"] = plot(res, plot_path) if plot_path else None
    return res


def plot(res, path):
    """Log-log RMSE against time, one line per pattern; returns the path,
    or a message if matplotlib is missing (the optional extra [plot])."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        msg = "plot skipped: matplotlib is not installed (pip install '.[plot]')"
        log(msg)
        return msg
    fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
    for p, marker in zip(PATTERNS, "osD^"):
        pr = [r for r in res["rows"] if r["pattern"] == p]
        ax.loglog([r["render_s"] for r in pr], [r["rmse"] for r in pr], marker=marker,
                  label=f"{p} (slope {res['slopes'][p]['from_4']:.2f}, N>=4)")
        for r in pr:
            if p == "random":
                ax.annotate(f"N={r['samples']}", (r["render_s"], r["rmse"]), fontsize=7,
                            textcoords="offset points", xytext=(4, 4))
    ax.axhline(res["reference"]["noise_rmse"], color="grey", ls="--", lw=0.8,
               label="reference's own noise (est.)")
    ax.set_xlabel("render time (s, median)")
    ax.set_ylabel("RMSE against reference (linear radiance)")
    ax.set_title(f"Soft shadows, teapot {res['width']}x{res['height']}: "
                 f"error vs time (reference {res['reference']['samples']} stratified)", fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    return common.save_figure(fig, path)


def markdown(res):
    out = [f"### Soft shadows: error against run time ({res['width']}x{res['height']}, "
           f"accel {res['accel']})", ""]
    header = ["Pattern", "N"] + ["Render s", "Runs", "RMSE", "PSNR dB"]
    body = [[r["pattern"], r["samples"], fmt_s(r["render_s"]), r["runs"], fmt_g(r["rmse"]),
             f"{r['psnr_db']:.1f}"]
            for p in PATTERNS for r in res["rows"] if r["pattern"] == p]
    out.append(markdown_table(header, body, align="lrrrrr"))
    ref = res["reference"]
    out += ["", markdown_table(
        ["Pattern", "Slope of log RMSE vs log N, N = 1..256", "N = 4..256"],
        [[p, f"{s['all']:.2f}", f"{s['from_4']:.2f}"] for p, s in res["slopes"].items()],
        align="lrr")]
    out += ["", (f"Teapot, soft shadows, seed {res['seed']}; reference: {ref['samples']} stratified "
                 f"samples, seed {ref['seeds'][0]}, same view and size ({fmt_s(ref['render_s'])} s). "
                 f"Its own noise, from a second reference (seed {ref['seeds'][1]}): RMSE "
                 f"{fmt_g(ref['noise_rmse'])} (PSNR {common.psnr(ref['noise_rmse']):.1f} dB), the floor "
                 f"under every error here. RMSE over all pixels and channels of the linear image; "
                 f"PSNR with peak 1. N = 1 is the light's centre for every pattern. Render time: "
                 f"median of up to {res['max_runs']} interleaved runs (budget {res['budget_s']:g} s "
                 f"a cell). Slope -0.5 is plain Monte Carlo; steeper converges faster.")]
    if res.get("plot"):
        out += ["", (f"Plot: `{res['plot']}`." if not res["plot"].startswith("plot skipped")
                     else res["plot"] + ".")]
    return "\n".join(out)


@click.command()
@click.option("--quick", is_flag=True, help="80x60 instead of 160x120.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default="bench-out/convergence.png",
              show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(quick, plot_path, json_path):
    """Soft-shadow error against time for each sampling pattern."""
    res = run(quick, plot_path)
    print(markdown(res))
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    main()
