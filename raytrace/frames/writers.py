"""Writing an animation's frames: an animated GIF, an MP4 video or a
numbered PNG per frame, never half a file.

    kind = check_frame_output(path)                 # before rendering
    with frame_output(path, n_frames, fps=24) as out:
        for i in range(n_frames):
            if not out.complete(i):                 # a PNG sequence resumed
                out.write(i, image)                 # (h, w, 3) uint8 sRGB
    # committed here; on an exception (or Ctrl-C) a .gif or .mp4 is not
    # written at all, and a PNG sequence keeps only its complete frames
"""
import os
import re
import tempfile
from fractions import Fraction
from numbers import Real
from pathlib import Path

import numpy as np

from raytrace.errors import RaytraceError, warn
from raytrace.renderer.output import (
    IMAGE_FORMATS,
    NAME_MAX,
    Outputs,
    check_writable,
    make_temp,
    temp_name,
    write_png,
)
from raytrace.scene.animation import check_frame_count

FPS_RANGE = (1.0, 240.0)
# printf's frame number: %d, or %0Nd zero-padded to N digits.
# A frame-number field, %d or %04d; "%%" is a literal "%", as in printf.
_FIELD_OR_PERCENT = re.compile(r"%%|%(\d*)d")


def number_fields(text):
    """The frame-number fields of ``text``, as match objects (group 1 the width)."""
    return [m for m in _FIELD_OR_PERCENT.finditer(text) if m.group(0) != "%%"]


def _literal(text):
    return text.replace("%%", "%")
EXAMPLE = "frames/spin_%04d.png"
VIDEO_EXTRA = "writing .mp4 needs the video extra: pip install 'raytrace[video]'"
# H.264 quality: x264's constant rate factor, 18 about where compression
# stops being visible on smooth renders (x264's default, 23, bands them).
MP4_CRF = "18"


def check_frame_output(path, resume=False):
    """What ``path`` writes -- "gif", "mp4" or "png-sequence" (a name with
    one %d or %0Nd field, ending in .png) -- or a RaytraceError, before
    any frame is rendered."""
    if not isinstance(path, (str, Path)):
        raise RaytraceError(f"frames output: expected a path, got {type(path).__name__}")
    path = Path(path)
    fields = [m.group(1) for m in number_fields(path.name)]
    ext = path.suffix.lower()
    if number_fields(str(path.parent)):
        raise RaytraceError(f"{path}: the frame number field belongs in the file name, "
                            f"not the directory (like {EXAMPLE})")
    if len(fields) > 1:
        raise RaytraceError(f"{path}: {len(fields)} frame number fields; a pattern has exactly one "
                            f"(like {EXAMPLE})")
    if fields and fields[0] and not fields[0].startswith("0"):
        raise RaytraceError(f"{path}: frame number field %{fields[0]}d pads with spaces; "
                            f"use %d or %0{fields[0]}d")
    if fields and ext in (".gif", ".mp4"):
        raise RaytraceError(f"{path}: a {ext} holds every frame in one file; drop the frame number field")
    if fields and ext != ".png":
        raise RaytraceError(f"{path}: frame sequences are written as PNG files; end the pattern in .png "
                            f"(like {EXAMPLE})")
    if fields:
        kind = "png-sequence"
    elif ext in (".gif", ".mp4"):
        kind = ext[1:]
    elif ext in IMAGE_FORMATS:
        raise RaytraceError(f"{path} writes one image; for frames use .gif, .mp4 or a pattern "
                            f"like {EXAMPLE}")
    else:
        raise RaytraceError(f"{path}: unknown animation format {ext or '(no extension)'!r} "
                            f"(use .gif, .mp4 or a pattern like {EXAMPLE})")
    if resume and kind != "png-sequence":
        raise RaytraceError(f"--resume needs a PNG sequence (a pattern like {EXAMPLE}); "
                            f"{path} is written whole at the end")
    if kind == "png-sequence":
        _check_sequence_dir(path)
    else:
        check_writable(path)
    return kind


def frame_path(pattern, i):
    """Frame i's file of a PNG sequence pattern: %04d and 7 give 0007."""
    pattern = Path(pattern)
    name = pattern.name
    m = number_fields(name)[0]
    number = str(i).zfill(int(m.group(1) or 0))
    return Path(_literal(str(pattern.parent))) / (_literal(name[:m.start()]) + number
                                                  + _literal(name[m.end():]))


def _check_sequence_dir(pattern):
    """A PNG sequence's directory takes files, or can be made: the nearest
    existing directory above it takes new entries."""
    first = frame_path(pattern, 0)
    folder = first.parent
    if folder.exists() or folder.is_symlink():
        if not folder.is_dir():
            raise RaytraceError(f"{pattern}: {folder} is not a directory")
        check_writable(first)
        return
    if len(first.name.encode()) > NAME_MAX:
        raise RaytraceError(f"{pattern}: file name longer than {NAME_MAX} bytes")
    above = folder.parent
    while not above.exists():
        above = above.parent
    if not above.is_dir():
        raise RaytraceError(f"{pattern}: cannot make directory {folder}: {above} is not a directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=".raytrace.", suffix=".probe", dir=above)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise RaytraceError(f"{pattern}: cannot make directory {folder} ({exc.strerror or exc})") from None


def check_fps(fps):
    """fps as a float from 1 to 240, or a RaytraceError."""
    if isinstance(fps, bool) or not isinstance(fps, Real) or not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:
        raise RaytraceError(f"fps must be a number from {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g}, got {fps!r}")
    return float(fps)


def frame_output(path, n_frames, fps=24, resume=False, size=None):
    """A FrameSequence writing ``n_frames`` frames to ``path`` (see
    check_frame_output), to use in a ``with`` block.  ``size``, (width,
    height) if known, is what a resumed PNG sequence's frames must have."""
    kind = check_frame_output(path, resume)
    n_frames = check_frame_count(n_frames, "n_frames")
    fps = check_fps(fps)
    out = {"gif": GifFrames, "mp4": Mp4Frames, "png-sequence": PngSequence}[kind](
        Path(path), n_frames, fps, resume)
    out.expected_size = size
    if kind == "png-sequence":
        out.check_existing()
    if kind == "gif" and size is not None:
        out.check_memory()
    return out


class FrameSequence:
    """Frames 0..n-1 of one output, all of one size, each written once;
    committed when its ``with`` block ends normally, abandoned otherwise."""
    kind = None

    def __init__(self, path, n_frames, fps, resume):
        self.path, self.n_frames, self.fps, self.resume = path, n_frames, fps, resume
        self.size = None      # (h, w) of the frames

    def complete(self, i):
        """Whether frame i is already written by an earlier run (resume)."""
        self._index(i)
        return False

    def write(self, i, image):
        i = self._index(i)
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise RaytraceError(f"{self.path}: frame {i}: expected an (h, w, 3) uint8 image, got "
                                f"{image.dtype} of shape {image.shape}")
        if self.size is None:
            self.size = image.shape[:2]
        elif image.shape[:2] != self.size:
            raise RaytraceError(f"{self.path}: frame {i} is {image.shape[1]}x{image.shape[0]}, "
                                f"the frames before it {self.size[1]}x{self.size[0]}")
        self._write(i, image)

    def _index(self, i):
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.n_frames:
            raise RaytraceError(f"{self.path}: frame index must be an integer from 0 to "
                                f"{self.n_frames - 1}, got {i!r}")
        return int(i)

    def _missing(self, written):
        if written < self.n_frames:
            raise RaytraceError(f"{self.path}: only {written} of {self.n_frames} frames were written; "
                                f"nothing saved")

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is not None:
            self._abort()
            return False
        try:
            self._commit()
        except BaseException:
            self._abort()
            raise
        return False

    def _write(self, i, image):
        raise NotImplementedError

    def _commit(self):
        pass

    def _abort(self):
        pass


class GifFrames(FrameSequence):
    """An animated GIF, looping forever, written whole at the end.

    One palette for every frame (median cut over pixels sampled from all
    of them), and Floyd-Steinberg dithering: per-frame palettes without
    dithering banded smooth shading into posterised steps, and a highlight
    could jump colour between frames.  The frames wait, zlib-compressed,
    until the palette can be chosen.  GIF counts time in hundredths of a
    second: each frame lasts a whole number of them, chosen so the frames
    so far have lasted ``i / fps`` rounded, which keeps 24 fps at 24
    (4, 4, 5 hundredths...), where one rounded duration gave 25.
    """
    kind = "gif"
    # Pixels the palette is chosen from: enough for 256 colours, few
    # enough to choose in a fraction of a second.
    PALETTE_SAMPLE = 1 << 18

    def __init__(self, *args):
        super().__init__(*args)
        self.frames = {}

    def _write(self, i, image):
        import zlib
        if i in self.frames:
            raise RaytraceError(f"{self.path}: frame {i} written twice")
        self.frames[i] = zlib.compress(np.ascontiguousarray(image).tobytes(), 1)

    def _frame(self, i):
        import zlib
        h, w = self.size
        return np.frombuffer(zlib.decompress(self.frames[i]), np.uint8).reshape(h, w, 3)

    def palette(self):
        """A 256-colour palette image fitted to pixels from every frame."""
        from PIL import Image
        h, w = self.size
        step = max(1, int(np.sqrt(h * w * self.n_frames / self.PALETTE_SAMPLE)))
        sample = np.concatenate([self._frame(i)[::step, ::step].reshape(-1, 3)
                                 for i in range(self.n_frames)])
        return Image.fromarray(sample[:, None, :]).quantize(256, method=Image.Quantize.MEDIANCUT)

    def durations(self):
        """Milliseconds of each frame, whole hundredths of a second."""
        ends = [round(100 * (i + 1) / self.fps) for i in range(self.n_frames)]
        return [10 * (b - a) for a, b in zip([0, *ends], ends)]

    def check_memory(self):
        """A GIF's frames are all kept until the end (one byte a pixel and
        a palette each): refuse, before rendering, more than free memory
        holds, with the estimate, rather than fill it."""
        from raytrace.scene.formats.mesh import available_memory
        need = self.n_frames * (self.expected_size[0] * self.expected_size[1] + 1024)
        free = available_memory()
        if need > free:
            raise RaytraceError(f"{self.path}: {self.n_frames:,} GIF frames of "
                                f"{self.expected_size[0]}x{self.expected_size[1]} are kept until "
                                f"the end, about {need / 2**30:.1f} GiB, more than the "
                                f"{free / 2**30:.1f} GiB free; write .mp4 or a PNG sequence, "
                                "which stream frame by frame")

    def _commit(self):
        from PIL import Image
        self._missing(len(self.frames))
        palette = self.palette()
        images = [Image.fromarray(self._frame(i)).quantize(palette=palette,
                                                           dither=Image.Dither.FLOYDSTEINBERG)
                  for i in range(self.n_frames)]
        durations = self.durations()
        with Outputs() as out:
            out.add(self.path, lambda fh: images[0].save(
                fh, format="GIF", save_all=True, append_images=images[1:], loop=0,
                duration=durations))
        self.frames = {}

    def _abort(self):
        self.frames = {}


class Mp4Frames(FrameSequence):
    """An H.264 MP4 (yuv420p, which plays everywhere) through PyAV, encoded
    frame by frame into a temporary file beside the target and renamed at
    the end.  yuv420p halves the colour resolution, so width and height
    must be even: an odd size is padded by repeating the last row or
    column (the video is one pixel larger, no rendered pixel is lost).
    Frames written out of order wait for the ones before them."""
    kind = "mp4"

    def __init__(self, *args):
        super().__init__(*args)
        try:
            import av
        except ImportError:
            raise RaytraceError(VIDEO_EXTRA) from None
        self.av = av
        self.container = self.stream = self.tmp = None
        self.next = 0          # the frame to encode next
        self.waiting = {}      # frames written before their turn

    def _write(self, i, image):
        if i < self.next or i in self.waiting:
            raise RaytraceError(f"{self.path}: frame {i} written twice")
        # A caller may reuse its buffer: a frame kept for later is copied.
        self.waiting[i] = image if i == self.next else image.copy()
        while self.next in self.waiting:
            self._encode(self.waiting.pop(self.next))
            self.next += 1

    def _errors(self):
        return (OSError, self.av.FFmpegError)

    def _open(self, h, w):
        self.tmp = temp_name(self.path)     # named before it exists: output.temp_name
        os.close(make_temp(self.tmp))
        self.container = self.av.open(self.tmp, "w", format="mp4")
        self.stream = self.container.add_stream("libx264", rate=Fraction(self.fps).limit_denominator(1001))
        self.stream.width, self.stream.height = w + w % 2, h + h % 2
        self.stream.pix_fmt = "yuv420p"
        self.stream.options = {"crf": MP4_CRF}

    def _encode(self, image):
        h, w = image.shape[:2]
        try:
            if self.container is None:
                self._open(h, w)
            if h % 2 or w % 2:
                image = np.pad(image, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
            frame = self.av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            for packet in self.stream.encode(frame):
                self.container.mux(packet)
        except self._errors() as exc:
            raise RaytraceError(f"{self.path}: cannot write ({exc})") from None

    def _commit(self):
        self._missing(self.next)
        try:
            for packet in self.stream.encode(None):   # flush the encoder's delayed frames
                self.container.mux(packet)
            self.container.close()
            self.container = None
        except self._errors() as exc:
            raise RaytraceError(f"{self.path}: cannot write ({exc})") from None
        with Outputs() as out:          # renamed into place as every output is
            out.adopt(self.path, self.tmp)
        self.tmp = None

    def _abort(self):
        self.waiting = {}
        if self.container is not None:
            try:
                self.container.close()
            except self._errors():
                pass    # the file goes anyway
            self.container = None
        if self.tmp is not None:
            try:
                os.unlink(self.tmp)
            except FileNotFoundError:
                pass
            self.tmp = None


class PngSequence(FrameSequence):
    """One PNG per frame, named by the pattern's number field, each written
    (temporary file, then rename) as soon as it is given: a run stopped
    half way leaves complete frames only, which a resumed run keeps.  The
    directory is made, with its parents, at the first frame if missing.
    Without resume, frames already there are replaced."""
    kind = "png-sequence"

    def frame_path(self, i):
        return frame_path(self.path, i)

    def check_existing(self):
        """Before any frame is rendered: with resume, which frames are there
        and whole (a PNG of the expected size that reads to its end: an empty,
        damaged or other-sized file is rendered again, with one warning);
        every other frame already there must be replaceable (not read-only,
        a regular file), so the run does not stop after frame 0."""
        self.kept = set()
        redo = []
        for i in range(self.n_frames):
            path = self.frame_path(i)
            if not (path.exists() or path.is_symlink()):
                continue
            if self.resume and _whole_png(path, self.expected_size):
                self.kept.add(i)
                continue
            if self.resume:
                redo.append(path)
            check_writable(path)
        if redo:
            size = "" if self.expected_size is None else "{}x{} ".format(*self.expected_size)
            warn(f"--resume: {len(redo)} frame file(s) are not whole {size}PNGs (first: {redo[0]}); "
                 "rendering them again")

    def complete(self, i):
        i = self._index(i)
        return self.resume and i in self.kept

    def _write(self, i, image):
        path = self.frame_path(i)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RaytraceError(f"{path}: cannot make directory {path.parent} "
                                f"({exc.strerror or exc})") from None
        write_png(path, image)



def _whole_png(path, size):
    """Whether ``path`` is a PNG that reads to its end (each chunk's CRC),
    of ``size`` (width, height) if given."""
    from PIL import Image
    try:
        with Image.open(path) as im:
            if im.format != "PNG" or size is not None and tuple(im.size) != tuple(size):
                return False
            im.verify()
        return True
    except Exception:      # Pillow raises many kinds for a damaged file
        return False
