"""Output files: every output of a run is written to a temporary file beside
its target and all are renamed into place together, so no run leaves half
a file or half of its files, and nothing but a regular file is replaced."""
import os
import secrets
import signal
import stat
import tempfile
from pathlib import Path

from raytrace.errors import RaytraceError

# Image formats by extension, written through Pillow.
IMAGE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".bmp": "BMP", ".tif": "TIFF",
                 ".tiff": "TIFF", ".webp": "WEBP"}
NAME_MAX = 255   # bytes in a file name on the usual file systems


def image_format(path):
    """Pillow's format name for an image path; RaytraceError otherwise."""
    ext = Path(path).suffix.lower()
    if ext not in IMAGE_FORMATS:
        raise RaytraceError(f"{path}: unknown image format {ext or '(no extension)'!r} "
                            f"(choose from {', '.join(IMAGE_FORMATS)})")
    return IMAGE_FORMATS[ext]


def target(path):
    """Where writing ``path`` really goes: a symbolic link's target (the
    link itself is kept)."""
    path = Path(path)
    return path.resolve() if path.is_symlink() else path


def check_writable(path):
    """Fail before rendering, not after, if the output cannot be written:
    a directory or something that is not a regular file (a device, a FIFO)
    is never replaced, a read-only file neither, and the directory must
    take a new file (tried: /proc and full or read-only file systems say
    so only when asked)."""
    path = Path(path)
    try:
        if len(path.name.encode()) > NAME_MAX:
            raise RaytraceError(f"{path}: file name longer than {NAME_MAX} bytes")
        real = target(path)
        if real.is_dir():
            raise RaytraceError(f"{path}: is a directory, not an output file")
        parent = real.parent if str(real.parent) else Path(".")
        if not parent.is_dir():
            raise RaytraceError(f"{path}: directory {parent} does not exist")
        if real.exists():
            if not stat.S_ISREG(real.stat().st_mode):
                raise RaytraceError(f"{path}: not a regular file; raytrace only replaces regular files")
            # The mode, not os.access: root may write anything, but a file
            # made read-only was meant to stay as it is.
            if not (real.stat().st_mode & 0o222) or not os.access(real, os.W_OK):
                raise RaytraceError(f"{path}: read-only; left as it is")
        fd, probe = tempfile.mkstemp(prefix=".raytrace.", suffix=".probe", dir=parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise RaytraceError(f"{path}: cannot write ({exc.strerror or exc})") from None


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temp_name(path):
    """A name for a new temporary file in the directory ``path`` is written
    to, so that the final rename stays on one file system.  The caller keeps
    it where its cleanup looks *before* make_temp creates the file: a
    SIGTERM landing between the two then leaves no file behind that the
    cleanup does not know of (blocking the signal cannot promise that: the
    kernel hands it to another thread, whose flag Python then acts on)."""
    real = target(path)
    folder = real.parent if str(real.parent) else Path(".")
    return str(folder / f".{real.name[:200]}.{secrets.token_hex(8)}.tmp")


def make_temp(name):
    """Create temp_name's file, private (0600) as mkstemp's: its descriptor."""
    return os.open(name, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o600)


def _give_mode(tmp, real):
    # mkstemp makes the file private (0600): a file replaced keeps its mode,
    # a new one gets the usual one.
    os.chmod(tmp, stat.S_IMODE(real.stat().st_mode) if real.exists() else 0o666 & ~_umask())


class Outputs:
    """The outputs of one run, committed together or not at all:

        with Outputs() as out:
            out.add("teapot.png", writer)      # writer(fileobj) fills a temporary file
            out.add("teapot.aov.npz", writer)
        # all renamed into place here; on an exception (or Ctrl-C) none is

    The renames run with SIGINT, SIGTERM and SIGHUP held back, so a signal lands
    before all of them or after all of them (``committed`` says which).
    """

    def __init__(self):
        self.pending = []
        self.committed = False

    def add(self, path, write):
        check_writable(path)
        tmp = temp_name(path)
        self.pending.append((tmp, target(path)))
        fd = make_temp(tmp)
        try:
            with os.fdopen(fd, "wb") as fh:
                write(fh)
            _give_mode(tmp, target(path))
        except OSError as exc:    # a full disk, a quota
            raise RaytraceError(f"{path}: cannot write ({exc.strerror or exc})") from None

    def adopt(self, path, tmp):
        """Commit ``tmp``, a finished file made by make_temp(temp_name(path))
        (written as it went, like a video), as ``path`` with the others."""
        self.pending.append((tmp, target(path)))
        try:
            _give_mode(tmp, target(path))
        except OSError as exc:
            raise RaytraceError(f"{path}: cannot write ({exc.strerror or exc})") from None

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is None:
            held = signal.pthread_sigmask(signal.SIG_BLOCK,
                                          {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
            try:
                for tmp, real in self.pending:
                    os.replace(tmp, real)
                self.committed = True
                self.pending = []
            except OSError as exc:
                raise RaytraceError(f"{real}: cannot write ({exc.strerror or exc})") from None
            finally:
                self._discard()
                signal.pthread_sigmask(signal.SIG_SETMASK, held)
        else:
            self._discard()
        return False

    def _discard(self):
        for tmp, _ in self.pending:
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass


def image_writer(image, path):
    """A writer of an (h, w, 3) uint8 image in the format ``path`` names."""
    from PIL import Image
    fmt = image_format(path)
    return lambda fh: Image.fromarray(image).save(fh, format=fmt)


def npz_writer(arrays):
    """A writer of a dict of arrays as an uncompressed .npz (np.load reads it)."""
    import numpy as np
    return lambda fh: np.savez(fh, **arrays)


def write_png(path, image):
    """Write one image (the format by the extension), atomically."""
    with Outputs() as out:
        out.add(path, image_writer(image, path))


def write_npz(path, arrays):
    with Outputs() as out:
        out.add(path, npz_writer(arrays))
