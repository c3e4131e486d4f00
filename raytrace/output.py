"""Output files are written atomically so no run leaves half a file."""
import os
import tempfile
from pathlib import Path

from .errors import RaytraceError


def check_writable(path):
    """Fail before rendering, not after, if the output cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise RaytraceError(f"{path}: is a directory, not an output file")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise RaytraceError(f"{path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise RaytraceError(f"{path}: directory {parent} is not writable")


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path, write):
    """Call write(fileobj) on a temporary file beside ``path``, then rename it
    over ``path``: an interrupted run leaves the old file or the new one,
    never a broken one."""
    path = Path(path)
    check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        # mkstemp makes the file private (0600); give it the usual mode.
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_png(path, image):
    """Write an (h, w, 3) uint8 image as PNG, atomically."""
    from PIL import Image

    write_atomic(path, lambda fh: Image.fromarray(image).save(fh, format="PNG"))


def write_npz(path, arrays):
    """A dict of arrays as an uncompressed .npz (np.load reads it), atomically."""
    import numpy as np
    write_atomic(path, lambda fh: np.savez(fh, **arrays))
