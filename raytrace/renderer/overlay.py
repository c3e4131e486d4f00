"""A structure drawn over its image: every box (BVH node, kd-tree cell,
grid cell, object box) down to a depth, as a wireframe coloured by depth,
so a student sees why some rays are cheap and some are not.

Boxes come from each structure's ``outline(layout, depth)``
(raytrace/accel/<name>.py); this module only projects and draws them.
"""
import numpy as np
from PIL import Image, ImageDraw

from raytrace.renderer.heatmap import colormap

# The 12 edges of a box whose corner k has x = k & 1, y = k & 2, z = k & 4.
EDGES = [(a, a | bit) for bit in (1, 2, 4) for a in range(8) if not a & bit]
NEAR = 1e-3   # edges are clipped this far in front of the eye, times the boxes' size


def _corners(lo, hi):
    """(k, 8, 3) corners of k boxes."""
    k = np.arange(8)
    pick = np.stack([(k >> axis) & 1 for axis in range(3)], axis=1).astype(bool)  # (8, 3)
    return np.where(pick[None], hi[:, None, :], lo[:, None, :])


def project(cam, points, width, height):
    """Pixel coordinates (x, y) and distance along the view axis of points
    (..., 3), by the pinhole the render uses (kernels/render.py)."""
    eye, fwd, right, up = cam[0:3], cam[3:6], cam[6:9], cam[9:12]
    d = points - eye
    z = d @ fwd
    sx = (d @ right) / (z * (right @ right))
    sy = (d @ up) / (z * (up @ up))
    return np.stack([(sx + 1.0) * 0.5 * width, (1.0 - sy) * 0.5 * height], axis=-1), z


def depth_colours(levels, deepest):
    """A colour per level: the viridis ramp from the root (purple) to
    ``deepest`` (yellow), brightened a little to stand out on a render."""
    x = np.asarray(levels, dtype=float) / max(1, deepest)
    return colormap(0.15 + 0.85 * x)


def draw_outline(image, cam, lo, hi, level, deepest):
    """A copy of ``image`` (h, w, 3) uint8 with the boxes lo..hi (k, 3)
    drawn over it, box i coloured by level[i]; the deepest first, so where
    boxes share an edge (a kd-tree cell and its parent) the edge keeps the
    colour of the level that made it."""
    h, w = image.shape[:2]
    img = Image.fromarray(np.ascontiguousarray(image))
    draw = ImageDraw.Draw(img)
    corners = _corners(np.asarray(lo, float), np.asarray(hi, float))
    extent = float(np.ptp(corners.reshape(-1, 3), axis=0).max()) if corners.size else 1.0
    near = NEAR * max(extent, 1e-300)
    colours = depth_colours(level, deepest)
    a_idx = [a for a, _ in EDGES]
    b_idx = [b for _, b in EDGES]
    for i in np.argsort(-np.asarray(level), kind="stable"):
        a, b = corners[i, a_idx], corners[i, b_idx]       # (12, 3) edge ends
        za, zb = (a - cam[0:3]) @ cam[3:6], (b - cam[0:3]) @ cam[3:6]
        keep = (za > near) | (zb > near)
        # Clip at the near plane: an end behind it moves to where the edge
        # crosses it.
        f = (near - za) / np.where(zb != za, zb - za, 1.0)
        cut = a + (b - a) * f[:, None]
        a2 = np.where((za > near)[:, None], a, cut)[keep]
        b2 = np.where((zb > near)[:, None], b, cut)[keep]
        pa, _ = project(cam, a2, w, h)
        pb, _ = project(cam, b2, w, h)
        colour = tuple(int(c) for c in colours[i])
        for (xa, ya), (xb, yb) in zip(pa, pb):
            draw.line([(xa, ya), (xb, yb)], fill=colour, width=1)
    return np.asarray(img)
