"""The path tracer: Monte Carlo error against run time, per sampler and
per structure, on the Cornell box.

For spp = 1, 2, 4, ..., render the Cornell box with each sampler
(independent, sobol) and each structure, and compare the linear image
with a reference: the mean of two high-spp Sobol renders of other seeds.
Each cell is rendered with SEEDS seeds, interleaved, and

    RMSE = sqrt(mean over seeds, pixels and channels of (image - reference)^2)

One seed is not enough: nine tenths of the squared error sits in the
few pixels the light's edge crosses (radiance 17 or about 0.5, as a
camera sample falls), so one render's RMSE swings by 1.5x from seed to
seed and a slope fitted to one seed's errors is off by 0.2 or more.  The
slope fitted to each seed's errors alone, their mean and its standard
error, say how far the slope over all seeds can be trusted: with 4 seeds
the standard error was about 0.035, hence 12 by default.

The reference's own noise (RMSE between its two halves / 2) adds to every
error in quadrature; "RMSE, net" subtracts it.  The slope is the
least-squares slope of log net RMSE against log render seconds for spp >=
4 (below that a render's fixed cost, the wave set-up, is a large share of
its time): -0.5 is plain Monte Carlo.  "At equal time" compares the
samplers' fitted lines at the independent sampler's 64-spp time (32
with --quick).  Every
structure gives the same image, so only their times differ.

    python bench/path_convergence.py [--quick] [--seeds N] [--plot FILE] [--json FILE]
"""
import json
import math
import sys
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402
from common import fmt_g, fmt_s, interleaved, log, markdown_table, median  # noqa: E402

SAMPLERS = ("independent", "sobol")
SEED, REFERENCE_SEEDS = 0, (101, 102)     # seeds SEED, SEED + 1, ... for the cells
FIT_FROM_SPP = 4
FULL = dict(size=64, spp=(1, 2, 4, 8, 16, 32, 64, 128), reference_spp=4096,
            accels=("bvh", "grid", "kdtree"), seeds=12)
QUICK = dict(size=32, spp=(1, 2, 4, 8, 16, 32), reference_spp=1024, accels=("bvh",),
             seeds=2)


def fit(rows):
    """(slope, intercept) of log net RMSE against log seconds, spp >= FIT_FROM_SPP."""
    pr = [r for r in rows if r["spp"] >= FIT_FROM_SPP and r["rmse_net"] > 0]
    lx = np.log([r["render_s"] for r in pr])
    ly = np.log([r["rmse_net"] for r in pr])
    b, a = np.polyfit(lx, ly, 1)
    return float(b), float(a)


def run(quick, plot_path=None, seeds=None):
    from raytrace import load_scene, render
    cfg = dict(QUICK if quick else FULL)
    cfg["seeds"] = seeds or cfg["seeds"]
    n = cfg["size"]
    scene = load_scene("cornell", width=n, height=n)
    log(f"path convergence: cornell {n}x{n}, references of {cfg['reference_spp']} spp (sobol)")
    refs = [render(scene, spp=cfg["reference_spp"], sampler="sobol", seed=s)
            for s in REFERENCE_SEEDS]
    ref = (refs[0].linear.astype(np.float64) + refs[1].linear) / 2
    ref_noise = common.rmse(refs[0].linear, refs[1].linear) / 2
    cells = [(a, s, spp) for spp in cfg["spp"] for a in cfg["accels"] for s in SAMPLERS]
    for a in cfg["accels"]:
        for s in SAMPLERS:
            render(scene, spp=2, sampler=s, accel=a, seed=SEED)     # compile or load

    mse = {c: [] for c in cells}

    def once(cell):
        a, s, spp = cell
        r = render(scene, spp=spp, sampler=s, accel=a, seed=SEED + len(mse[cell]))
        mse[cell].append(common.rmse(r.linear, ref) ** 2)
        return common.render_time(r), None
    k = cfg["seeds"]
    times, _ = interleaved(cells, once, 0.0, k, min_runs=k)
    rows = []
    for a, s, spp in cells:
        err = math.sqrt(float(np.mean(mse[a, s, spp])))
        rows.append({"accel": a, "sampler": s, "spp": spp, "render_s": median(times[a, s, spp]),
                     "runs": len(times[a, s, spp]), "rmse": err,
                     "rmse_each": [math.sqrt(x) for x in mse[a, s, spp]],
                     "rmse_net": math.sqrt(max(err * err - ref_noise * ref_noise, 0.0))})
    fits = {}
    for a in cfg["accels"]:
        for s in SAMPLERS:
            pr = [r for r in rows if r["accel"] == a and r["sampler"] == s]
            slope, icpt = fit(pr)
            fitted = [r for r in pr if r["spp"] >= FIT_FROM_SPP]
            each = [common.loglog_slope([r["spp"] for r in fitted],
                                        [r["rmse_each"][j] for r in fitted]) for j in range(k)]
            fits[f"{a}/{s}"] = {"slope_time": slope, "intercept": icpt,
                                "slope_spp": common.loglog_slope(
                                    [r["spp"] for r in fitted], [r["rmse_net"] for r in fitted]),
                                "slope_spp_each": each,
                                "slope_spp_se": float(np.std(each, ddof=1) / math.sqrt(k))
                                if k > 1 else None}
    equal = {}
    at_spp = min(64, max(cfg["spp"]))
    for a in cfg["accels"]:
        t = next(r["render_s"] for r in rows if r["accel"] == a and r["sampler"] == "independent"
                 and r["spp"] == at_spp)
        e = {s: math.exp(fits[f"{a}/{s}"]["intercept"] + fits[f"{a}/{s}"]["slope_time"]
                         * math.log(t)) for s in SAMPLERS}
        equal[a] = {"at_spp": at_spp, "at_s": t, "independent": e["independent"], "sobol": e["sobol"],
                    "ratio": e["independent"] / e["sobol"]}
    res = {"scene": "cornell", "size": n, "seed": SEED, "fit_from_spp": FIT_FROM_SPP,
           "reference": {"spp": cfg["reference_spp"], "sampler": "sobol",
                         "seeds": list(REFERENCE_SEEDS), "noise_rmse": ref_noise,
                         "render_s": [common.render_time(r) for r in refs]},
           "seeds": k, "rows": rows, "fits": fits,
           "equal_time": equal}
    res["plot"] = plot(res, plot_path) if plot_path else None
    return res


def plot(res, path):
    """Log-log net RMSE against time, a line per sampler and structure."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        msg = "plot skipped: matplotlib is not installed (pip install '.[plot]')"
        log(msg)
        return msg
    fig, ax = plt.subplots(figsize=(7.5, 5.2), dpi=110)
    styles = {"bvh": "-", "grid": "--", "kdtree": ":"}
    colours = {"independent": "tab:blue", "sobol": "tab:red"}
    for key, f in res["fits"].items():
        a, s = key.split("/")
        pr = [r for r in res["rows"] if r["accel"] == a and r["sampler"] == s]
        ax.loglog([r["render_s"] for r in pr], [r["rmse_net"] for r in pr], styles.get(a, "-"),
                  marker="o" if s == "sobol" else "s", ms=3.5, color=colours[s],
                  label=f"{s}, {a} (slope {f['slope_time']:.3f})")
        if a == "bvh" and s == "independent":
            for r in pr:
                ax.annotate(f"{r['spp']}", (r["render_s"], r["rmse_net"]), fontsize=7,
                            textcoords="offset points", xytext=(3, 4))
    ref = res["reference"]
    ax.set_xlabel("render time (s, median of interleaved runs)")
    ax.set_ylabel("RMSE against reference, less its own noise")
    ax.set_title(f"Cornell box {res['size']}x{res['size']}, --integrator path: error against "
                 f"time (reference 2 x {ref['spp']} spp; numbers: spp)", fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    return common.save_figure(fig, path)


def markdown(res):
    out = [f"### Path tracer: error against run time (Cornell box {res['size']}x{res['size']})", ""]
    header = ["Structure", "Sampler", "spp", "Render s", "Seeds", "RMSE", "RMSE, net"]
    body = [[r["accel"], r["sampler"], r["spp"], fmt_s(r["render_s"]), r["runs"],
             fmt_g(r["rmse"]), fmt_g(r["rmse_net"])] for r in res["rows"]]
    out.append(markdown_table(header, body, align="llrrrrr"))
    out += ["", markdown_table(
        ["Structure/sampler", f"Slope vs seconds (spp >= {res['fit_from_spp']})", "Slope vs spp",
         "Each seed's slope vs spp: mean +- standard error"],
        [[k, f"{f['slope_time']:.3f}", f"{f['slope_spp']:.3f}",
          f"{np.mean(f['slope_spp_each']):.3f} +- {f['slope_spp_se']:.3f}"
          if f["slope_spp_se"] is not None else "-"] for k, f in res["fits"].items()],
        align="lrrr")]
    out += ["", markdown_table(
        ["Structure", "At s", "Independent RMSE", "Sobol RMSE", "Ratio"],
        [[a, fmt_s(e["at_s"]), fmt_g(e["independent"]), fmt_g(e["sobol"]), f"{e['ratio']:.2f}"]
         for a, e in res["equal_time"].items()], align="lrrrr")]
    ref = res["reference"]
    out += ["", (f"Seeds {res['seed']} to {res['seed'] + res['seeds'] - 1}, RMSE over all of them; "
                 f"reference: the mean of two {ref['spp']}-spp Sobol renders "
                 f"(seeds {ref['seeds']}), its own noise {fmt_g(ref['noise_rmse'])} RMSE, "
                 f"subtracted in quadrature (net). Fits from the fitted lines; equal time at the "
                 f"independent sampler's {next(iter(res['equal_time'].values()))['at_spp']}-spp "
                 f"render time. Render time: median of the "
                 f"{res['seeds']} interleaved runs.")]
    if res.get("plot"):
        out += ["", f"Plot: `{res['plot']}`."]
    return "\n".join(out)


@click.command()
@click.option("--quick", is_flag=True, help="32x32, up to 32 spp, 2 seeds, the BVH only.")
@click.option("--seeds", type=click.IntRange(2, 64), default=None,
              help="Renders a cell, each of its own seed (default 12; --quick 2).")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              default="bench-out/path_convergence.png", show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(quick, seeds, plot_path, json_path):
    """The path tracer's error against time for each sampler and structure."""
    res = run(quick, plot_path, seeds)
    print(markdown(res))
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    main()
