"""What a render looks like in a notebook and how it is saved: PNG bytes
for Jupyter's ``_repr_png_``, short reprs, and ``save(path)`` by extension
(8-bit formats from the sRGB image, .npy/.pfm/.exr from the linear one)."""
import io
from pathlib import Path

from raytrace.errors import RaytraceError


def png_bytes(image):
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    return buf.getvalue()


def save_result(result, path):
    """Write a RenderResult's image to ``path`` (atomically), in the format
    its extension names; returns the path."""
    from raytrace.renderer import linear
    from raytrace.renderer.output import Outputs, image_writer
    path = Path(path)
    if linear.is_linear(path):
        if result.linear is None:
            raise RaytraceError(f"{path}: this result has no linear image (rendered in tiles); "
                                "save it as .png")
        linear.check_available(path)
        write = linear.writer(result.linear, path)
    else:
        write = image_writer(result.image, path)
    with Outputs() as out:
        out.add(path, write)
    return path


def result_repr(result):
    s = result.stats or {}
    h, w = result.image.shape[:2]
    t = s.get("time", {})
    parts = [f"{w}x{h}", f"scene={s.get('scene')!r}", f"accel={s.get('accel')!r}",
             f"shadows={s.get('shadows')!r}"]
    if "render_s" in t:
        parts.append(f"render_s={t['render_s']:.3g}")
    rays = s.get("derived", {}).get("rays")
    if rays is not None:
        parts.append(f"rays={rays:,}")
    if result.aovs:
        parts.append(f"aovs={sorted(result.aovs)}")
    return f"RenderResult({', '.join(parts)})"
