"""False-colour images of per-pixel cost (box tests + primitive tests).

Colour map: viridis (van der Walt & Smith 2015), perceptually uniform,
readable in grey and by colour-blind viewers: dark purple is the cheapest
pixel, through blue and green, to yellow for the most expensive.  The
scale is logarithmic, log(1 + cost) from the image's minimum to its
maximum, because costs span orders of magnitude (a background pixel may
cost one plane test, a silhouette pixel thousands of triangle tests).

Below the image a legend strip shows the ramp from minimum (left) to
maximum (right), with a tick at each power of ten inside the range.
"""
import numpy as np

# viridis at 0, 1/8, ..., 1 (sRGB); linear interpolation between these nine
# stays within a few levels of the full 256-entry table.
VIRIDIS = np.array([
    [0x44, 0x01, 0x54], [0x47, 0x2d, 0x7b], [0x3b, 0x52, 0x8b], [0x2c, 0x72, 0x8e],
    [0x21, 0x91, 0x8c], [0x28, 0xae, 0x80], [0x5e, 0xc9, 0x62], [0xad, 0xdc, 0x30],
    [0xfd, 0xe7, 0x25]], dtype=np.float64)


def colormap(x):
    """sRGB uint8 colours of values x in [0, 1] (clipped), shape x.shape + (3,)."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    pos = x * (len(VIRIDIS) - 1)
    i = np.minimum(pos.astype(np.int64), len(VIRIDIS) - 2)
    f = (pos - i)[..., None]
    rgb = VIRIDIS[i] * (1.0 - f) + VIRIDIS[i + 1] * f
    return (rgb + 0.5).astype(np.uint8)


def log_scale(cost, lo, hi):
    """Positions in [0, 1] of costs on the log1p scale from lo to hi (all
    0 when lo == hi)."""
    llo, lhi = np.log1p(lo), np.log1p(hi)
    span = lhi - llo if hi > lo else 1.0
    return (np.log1p(np.asarray(cost, dtype=np.float64)) - llo) / span


def legend_height(height):
    """Rows of the legend strip: a twelfth of the image, at least 4."""
    return max(4, height // 12)


def cost_heatmap(cost):
    """(image (h + legend, w, 3) uint8, min cost, max cost) of a (h, w) cost
    array; a constant image maps to the bottom colour."""
    cost = np.asarray(cost)
    h, w = cost.shape
    lo, hi = int(cost.min()), int(cost.max())
    body = colormap(log_scale(cost, lo, hi))

    rows = legend_height(h)
    ramp = np.linspace(0.0, 1.0, w) if w > 1 else np.zeros(1)
    strip = np.repeat(colormap(ramp)[None], rows, axis=0)
    strip[0] = 0  # a black rule between image and legend
    decade = 1                               # a tick at each power of ten
    while decade <= hi and hi > lo:
        if decade >= lo:
            x = int(round(log_scale(decade, lo, hi) * (w - 1)))
            strip[rows // 2:, x] = 255
        decade *= 10
    return np.concatenate([body, strip], axis=0), lo, hi
