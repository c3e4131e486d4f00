"""The comparison as one picture (``SCENE.compare.png``), the slide a
teacher shows: the image, each structure's cost heatmap on one shared
colour scale with its name and figures, the scale, and a bar chart of
render time.  Drawn with Pillow alone (a dependency already).
"""
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from raytrace.cli.compare import identity_line, rows, speedup_text
from raytrace.renderer.heatmap import colormap, log_scale

BACKGROUND = (255, 255, 255)
INK = (34, 34, 34)
MUTED = (110, 110, 110)
GOOD = (20, 120, 60)
BAD = (190, 30, 30)
BAR = (33, 145, 140)           # viridis' middle: the heatmaps' own palette
COLUMNS = 3


def _font(size):
    """Pillow's bundled scalable font (Pillow >= 10.1 with FreeType);
    its fixed bitmap font otherwise."""
    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError, ImportError):
        return ImageFont.load_default()


def _text_w(draw, text, font):
    left, _, right, _ = draw.textbbox((0, 0), text, font=font)
    return right - left


def figure(comparison, setting):
    """(figure (H, W, 3) uint8, panels): the comparison as one picture and
    where each panel lies, {"image" or label: (x, y, width, height)}.
    ``setting``: one line saying how the scene was rendered."""
    h, w = comparison.image.shape[:2]
    # Panels at least 320 wide so the captions fit; small renders are
    # enlarged by whole pixels, never smoothed.
    zoom = max(1, -(-320 // w))
    pw, ph = w * zoom, h * zoom
    big = 20 if pw >= 480 else 15
    title_f, head_f, body_f = _font(big + 4), _font(big), _font(big - 4)
    pad = big
    line = big + 6

    table = rows(comparison)
    costs = [e.cost for e in comparison.entries]
    lo = min(int(c.min()) for c in costs)
    hi = max(int(c.max()) for c in costs)
    panels = [("image", comparison.image, None)]
    for e, r in zip(comparison.entries, table):
        heat = colormap(log_scale(e.cost, lo, hi))
        panels.append((e.label, heat, r))

    cols = min(COLUMNS, len(panels))
    grid_rows = -(-len(panels) // cols)
    caption = 2 * line
    cell_h = caption + ph + pad
    width = pad + cols * (pw + pad)
    top = pad + 2 * line + pad
    legend_top = top + grid_rows * cell_h
    legend_h = line + 14 + line + pad
    chart_top = legend_top + legend_h
    bar_h = line
    chart_h = line + len(table) * (bar_h + 6) + pad
    height = chart_top + chart_h

    img = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(img)

    # Title, setting and the identity check.
    draw.text((pad, pad), f"{comparison.scene}: what each structure buys", font=title_f, fill=INK)
    draw.text((pad, pad + line + 4), setting, font=body_f, fill=MUTED)
    verdict = identity_line(comparison)
    draw.text((width - pad - _text_w(draw, verdict, body_f), pad + line + 4), verdict,
              font=body_f, fill=GOOD if comparison.identical else BAD)

    where = {}
    for k, (name, pixels, r) in enumerate(panels):
        x = pad + (k % cols) * (pw + pad)
        y = top + (k // cols) * cell_h
        draw.text((x, y), name, font=head_f, fill=INK)
        if r is None:
            note = "the same from every structure" if comparison.identical else "from the first"
        else:
            note = (f"{r['render_s']:.3f} s   {speedup_text(r['speedup'])}   "
                    f"{r['prim_tests_per_ray']:,.1f} prim + {r['box_tests_per_ray']:,.1f} box tests/ray")
        draw.text((x, y + line), note, font=body_f, fill=MUTED)
        tile = Image.fromarray(np.ascontiguousarray(pixels))
        if zoom > 1:
            tile = tile.resize((pw, ph), Image.NEAREST)
        img.paste(tile, (x, y + caption))
        where[name] = (x, y + caption, pw, ph)

    _legend(draw, img, pad, legend_top, width - 2 * pad, lo, hi, body_f, line)
    _bars(draw, pad, chart_top, width - 2 * pad, table, comparison.baseline.label,
          body_f, line, bar_h)
    return np.asarray(img), where


def _legend(draw, img, x, y, span, lo, hi, font, line):
    """The shared colour scale, with the cost at each power of ten."""
    draw.text((x, y), "cost per pixel: box + primitive tests (log scale, one scale for all)",
              font=font, fill=INK)
    ramp = colormap(np.linspace(0.0, 1.0, span))
    strip = np.repeat(ramp[None], 14, axis=0)
    img.paste(Image.fromarray(strip), (x, y + line))
    ticks = [lo] + [10 ** k for k in range(0, 20) if lo < 10 ** k < hi] + [hi]
    last_right = -1
    for c in ticks:
        pos = x + int(round(float(log_scale(np.array([c]), lo, hi)[0]) * (span - 1)))
        label = f"{c:,}"
        tw = _text_w(draw, label, font)
        left = min(max(x, pos - tw // 2), x + span - tw)
        if left <= last_right + 6 and c != hi:
            continue                         # no labels on top of each other
        draw.line([(pos, y + line), (pos, y + line + 14)], fill=INK)
        draw.text((left, y + line + 16), label, font=font, fill=INK)
        last_right = left + tw


def _bars(draw, x, y, span, table, baseline, font, line, bar_h):
    """Render time per structure, one linear scale: brute force's bar is
    long, a hierarchy's a sliver; that is the point."""
    draw.text((x, y), f"render time (s); speedup over {baseline}", font=font, fill=INK)
    label_w = max(_text_w(draw, r["structure"], font) for r in table) + 12
    value_w = max(_text_w(draw, _bar_value(r), font) for r in table) + 12
    longest = max(r["render_s"] for r in table) or 1.0
    for k, r in enumerate(table):
        top = y + line + k * (bar_h + 6)
        draw.text((x, top + 2), r["structure"], font=font, fill=INK)
        length = max(1, int((span - label_w - value_w) * r["render_s"] / longest))
        draw.rectangle([x + label_w, top, x + label_w + length, top + bar_h - 2], fill=BAR)
        draw.text((x + label_w + length + 8, top + 2), _bar_value(r), font=font, fill=INK)


def _bar_value(r):
    return f"{r['render_s']:.3f} s   {speedup_text(r['speedup'])}"
