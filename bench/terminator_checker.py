"""The first picture's two artefacts, measured: the faceted shadow
terminator and the aliased checkerboard (issue 17).

Terminator: the teapot at --detail 4 (the workshop's 992 triangles)
against --detail 64 (253,952 triangles, a smooth reference), same view,
hard shadows.  The error is the mean absolute difference of the 8-bit
sRGB values over the pixels that both renders see on the teapot, minus
its silhouette (a pixel whose 4-neighbours are not all teapot in both:
the outline itself moves with the tessellation):

    MAD = mean over those pixels and the 3 channels of |a - b|, in levels (0-255)

Most of that difference is not the terminator's: the coarse spout, handle
and knob have other shapes and highlights, and 992 triangles' interpolated
normals are not the smooth surface's.  So the same is also reported over
the teapot's body alone (where the terminator crosses the big facets),
with the number of its pixels that differ visibly (by more than VISIBLE
levels in a channel): the facet patches are such pixels.

Checker: the teapot scene without shadows (so that only the texture
differs), at 1 sample per pixel, against a reference of the raw
point-sampled checker at 256 jittered samples per pixel (a box pixel
filter, the integral the filtered checker computes in closed form).
The error is the RMSE of the linear values over the far half of the
ground: ground pixels (minus the ground's outline) farther than the
median distance of all of them.

    python bench/terminator_checker.py [--quick] [--json FILE] [--images DIR]
"""
import json
import sys
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402
from common import log  # noqa: E402

DETAIL, REFERENCE_DETAIL = 4, 64
REFERENCE_SPP = 256
# The terminator band: lit pixels whose smooth normal is within ~24 degrees
# of the light's horizon (cosine below sin 24 = 0.4), about the angle a
# facet spans at --detail 4 (4 quads across a patch's 90 degrees): where
# the facets' shadows fall on each other.
TERMINATOR_BAND = 0.4
# A pixel's error is visible at a glance above 16 levels (of 255) in a
# channel: the facet patches' edges step by 20-40 levels, while the smooth
# differences of interpolated normals stay mostly below 8.
VISIBLE = 16
FULL = dict(width=640, height=480)
QUICK = dict(width=160, height=120)


def _interior(mask):
    """mask minus every pixel with a 4-neighbour outside it (or off the image)."""
    m = mask.copy()
    m[1:] &= mask[:-1]
    m[:-1] &= mask[1:]
    m[:, 1:] &= mask[:, :-1]
    m[:, :-1] &= mask[:, 1:]
    m[0] = m[-1] = False
    m[:, 0] = m[:, -1] = False
    return m


def teapot_pixels(result):
    """Pixels whose camera ray hit a teapot triangle."""
    prim = result.aovs["primid"]
    return (prim >= 0) & (prim < result.stats["triangles"])


# Newell's patches 4-11 are the body (the rim is 0-3, then handle, spout,
# lid and bottom); each patch is detail x detail quads, 2 triangles each, and
# no patch before 12 has a degenerate triangle, so flattening keeps the body's
# triangles at these ids.
BODY_PATCHES = range(4, 12)


def body_pixels(result, detail):
    """Pixels whose camera ray hit the teapot's body: where the terminator
    crosses the big facets.  The spout, handle and knob of a coarse teapot
    differ in shape from the smooth one's, so their outlines and highlights
    move by many levels whatever the shadows do."""
    per_patch = 2 * detail * detail
    prim = result.aovs["primid"]
    return (prim >= BODY_PATCHES.start * per_patch) & (prim < BODY_PATCHES.stop * per_patch)


def light_cosine(scene, result):
    """Per pixel, the cosine between the recorded shading normal and the
    direction to the scene's (first) light, at the first camera hit."""
    from raytrace.renderer.driver import camera_buffer
    h, w = result.aovs["depth"].shape
    cam = camera_buffer(scene.camera, w, h)
    sx = 2.0 * (np.arange(w) + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (np.arange(h) + 0.5) / h
    d = cam[3:6] + sx[None, :, None] * cam[6:9] + sy[:, None, None] * cam[9:12]
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    with np.errstate(invalid="ignore"):
        p = cam[:3] + result.aovs["depth"][..., None].astype(np.float64) * d
        to_light = np.asarray(scene.lights[0].position, float) - p
        to_light /= np.linalg.norm(to_light, axis=2, keepdims=True)
        return np.einsum("ijk,ijk->ij", result.aovs["normal"].astype(np.float64), to_light)


def terminator_error(width, height, detail=DETAIL, reference_detail=REFERENCE_DETAIL, **kw):
    """Mean absolute difference, in 8-bit levels, of --detail `detail`
    against `reference_detail`: a dict with ``mad`` over the teapot's
    interior pixels and ``band_mad`` over those of them in the terminator
    band (the reference's normal within TERMINATOR_BAND of the light's
    horizon, lit side), their pixel counts, and the two results."""
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    opts = dict(dict(accel="bvh", shadows="hard", width=width, height=height, aov=True), **kw)
    coarse = render(teapot(detail), **opts)
    smooth_scene = teapot(reference_detail)
    smooth = render(smooth_scene, **opts)
    mask = _interior(teapot_pixels(coarse) & teapot_pixels(smooth))
    cos = light_cosine(smooth_scene, smooth)
    band = mask & (cos > 0.0) & (cos < TERMINATOR_BAND)
    body = mask & _interior(body_pixels(coarse, detail) & body_pixels(smooth, reference_detail))
    diff = np.abs(coarse.image.astype(np.float64) - smooth.image.astype(np.float64))
    visible = diff.max(axis=2) > VISIBLE
    return dict(mad=float(diff[mask].mean()), pixels=int(mask.sum()),
                band_mad=float(diff[band].mean()), band_pixels=int(band.sum()),
                body_mad=float(diff[body].mean()), body_pixels=int(body.sum()),
                body_visible=int((visible & body).sum()), coarse=coarse, smooth=smooth)


def far_ground(result):
    """The far half of the ground's interior pixels (by distance)."""
    prim = result.aovs["primid"]
    ground = _interior(prim == result.stats["triangles"] + result.stats["spheres"])
    depth = result.aovs["depth"]
    return ground & (depth > np.median(depth[ground]))


def checker_error(width, height, texture_filter, reference=None, reference_spp=REFERENCE_SPP):
    """(RMSE of the linear image over the far half of the ground, pixels,
    the 1-spp result, the reference) for one texture filter; `reference`
    (a result of the raw checker at many samples) is rendered if None."""
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    opts = dict(accel="bvh", shadows="none", width=width, height=height, aov=True)
    if reference is None:
        reference = render(teapot(DETAIL), spp=reference_spp, texture_filter="none", **opts)
    one = render(teapot(DETAIL), spp=1, texture_filter=texture_filter, **opts)
    mask = far_ground(one)
    return common.rmse(one.linear[mask], reference.linear[mask]), int(mask.sum()), one, reference


@click.command()
@click.option("--quick", is_flag=True, help=f"{QUICK['width']}x{QUICK['height']} instead of "
              f"{FULL['width']}x{FULL['height']}.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
@click.option("--images", type=click.Path(file_okay=False), default=None,
              help="Also write the renders compared, as PNGs, into this directory.")
def main(quick, json_path, images):
    from raytrace.renderer.output import write_png
    cfg = QUICK if quick else FULL
    w, h = cfg["width"], cfg["height"]
    log(f"terminator: teapot --detail {DETAIL} against --detail {REFERENCE_DETAIL}, {w}x{h}")
    term = terminator_error(w, h)
    coarse, smooth = term.pop("coarse"), term.pop("smooth")
    log(f"checker: 1 spp against {REFERENCE_SPP} spp of the raw checker, {w}x{h}")
    rows, ref, shots = {}, None, {}
    for filt in ("none", "box"):
        err, n_gr, one, ref = checker_error(w, h, filt, reference=ref)
        rows[filt] = err
        shots[f"checker_{filt}"] = one
    # The reference's own noise: a second one with another seed, RMSE
    # between the two / sqrt 2 (an error near it is as good as measurable).
    from raytrace.renderer.driver import render
    from raytrace.scene.builtin import teapot
    ref2 = render(teapot(DETAIL), spp=REFERENCE_SPP, texture_filter="none", seed=1, accel="bvh",
                  shadows="none", width=w, height=h)
    mask = far_ground(shots["checker_box"])
    noise = common.rmse(ref.linear[mask], ref2.linear[mask]) / np.sqrt(2.0)
    res = {"width": w, "height": h,
           "terminator": {"detail": DETAIL, "reference_detail": REFERENCE_DETAIL, **term,
                          "shadow_rays": coarse.stats["counters"]["shadow_rays"]},
           "checker": {"reference_spp": REFERENCE_SPP, "pixels": n_gr,
                       "rmse": rows, "reference_noise_rmse": noise}}
    click.echo(f"terminator: detail {DETAIL} vs {REFERENCE_DETAIL}, mean absolute difference "
               f"(8-bit sRGB levels): {term['mad']:.3f} over {term['pixels']} teapot pixels, "
               f"{term['band_mad']:.3f} over the {term['band_pixels']} in the terminator band")
    click.echo(f"terminator, the body only (patches 4-11): mean absolute difference "
               f"{term['body_mad']:.3f} over {term['body_pixels']} pixels, of which "
               f"{term['body_visible']} differ by more than {VISIBLE} levels")
    for filt, err in rows.items():
        click.echo(f"checker --texture-filter {filt}: RMSE over {n_gr} far-ground pixels vs "
                   f"{REFERENCE_SPP} spp raw: {err:.4f} (linear)")
    click.echo(f"checker reference's own noise there (two seeds): RMSE {noise:.4f}")
    if images:
        out = Path(images)
        out.mkdir(parents=True, exist_ok=True)
        shots.update({f"teapot_detail{DETAIL}": coarse, f"teapot_detail{REFERENCE_DETAIL}": smooth,
                      f"checker_reference_{REFERENCE_SPP}spp": ref})
        for name, r in shots.items():
            write_png(out / f"{name}.png", r.image)
        log(f"wrote {len(shots)} images to {out}")
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
