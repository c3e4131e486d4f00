"""False-colour images of per-pixel cost (box tests + primitive tests).

Colour map: viridis (van der Walt & Smith 2015), perceptually uniform,
readable in grey and by colour-blind viewers: dark purple is the cheapest
pixel, through blue and green, to yellow for the most expensive.  The
scale is logarithmic, log(1 + cost) from the image's minimum to its
maximum, because costs span orders of magnitude (a background pixel may
cost one plane test, a silhouette pixel thousands of triangle tests).

Below the image a legend strip shows the ramp from minimum (left) to
maximum (right), with a tick at each power of ten inside the range, and
under it the costs themselves (minimum, powers of ten, maximum), so the
picture keeps its scale without the terminal's line.
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
    """Rows of the legend strip (a twelfth of the image, at least 4) and of
    its numbers under it."""
    return max(4, height // 12) + label_height(height)


def label_height(height):
    return label_size(height) + 4


def label_size(height):
    """Pixel size of the legend's numbers: readable, and small beside a small image."""
    return max(10, min(24, height // 24))


def _labels(width, height, lo, hi, ticks):
    """(rows, width, 3) uint8: the costs at ``ticks`` written under their
    places on the ramp, white on black; labels that would overlap are left
    out, the maximum kept."""
    from PIL import Image, ImageDraw, ImageFont
    size = label_size(height)
    try:
        font = ImageFont.load_default(size=size)
    except (TypeError, OSError, ImportError):      # no FreeType: the bitmap font
        font = ImageFont.load_default()
    img = Image.new("RGB", (width, label_height(height)), (0, 0, 0))
    draw = ImageDraw.Draw(img)
    placed = []
    for c in sorted(ticks, key=lambda c: (c != lo and c != hi, c)):      # ends first
        label = f"{c:,}"
        left_, _, right_, _ = draw.textbbox((0, 0), label, font=font)
        tw = right_ - left_
        pos = int(round(float(log_scale(c, lo, hi)) * (width - 1)))
        left = min(max(0, pos - tw // 2), max(0, width - tw))
        if any(left < b + 4 and a < left + tw + 4 for a, b in placed):
            continue
        placed.append((left, left + tw))
        draw.text((left - left_, 1), label, font=font, fill=(255, 255, 255))
    return np.asarray(img)


def cost_heatmap(cost):
    """(image (h + legend, w, 3) uint8, min cost, max cost) of a (h, w) cost
    array; a constant image maps to the bottom colour."""
    cost = np.asarray(cost)
    h, w = cost.shape
    lo, hi = int(cost.min()), int(cost.max())
    body = colormap(log_scale(cost, lo, hi))

    rows = legend_height(h) - label_height(h)
    ramp = np.linspace(0.0, 1.0, w) if w > 1 else np.zeros(1)
    strip = np.repeat(colormap(ramp)[None], rows, axis=0)
    strip[0] = 0  # a black rule between image and legend
    ticks = [lo, hi]
    decade = 1                               # a tick at each power of ten
    while decade <= hi and hi > lo:
        if decade >= lo:
            x = int(round(log_scale(decade, lo, hi) * (w - 1)))
            strip[rows // 2:, x] = 255
            ticks.append(decade)
        decade *= 10
    labels = _labels(w, h, lo, hi, sorted(set(ticks)))
    return np.concatenate([body, strip, labels], axis=0), lo, hi
