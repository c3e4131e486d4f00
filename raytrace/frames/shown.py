"""render_frames' frames as a notebook shows them and saves them."""
from pathlib import Path

from raytrace.renderer.display import png_bytes

# A frame sequence shows this many frames side by side in a notebook.
STRIP_FRAMES = 6


class Frames(list):
    """render_frames' frames: a list of (h, w, 3) uint8 images that shows
    itself in a notebook (a strip of up to STRIP_FRAMES of them) and saves
    itself as .gif, .mp4 or a PNG pattern."""

    def save(self, path, fps=24):
        from raytrace.frames.writers import frame_output
        with frame_output(path, len(self), fps=fps) as out:
            for i, image in enumerate(self):
                out.write(i, image)
        return Path(path)

    def _repr_png_(self):
        import numpy as np
        if not self:
            return None
        step = max(1, -(-len(self) // STRIP_FRAMES))
        return png_bytes(np.concatenate(self[::step], axis=1))

    def __repr__(self):
        if not self:
            return "Frames([])"
        h, w = self[0].shape[:2]
        return f"Frames({len(self)} frames of {w}x{h})"
