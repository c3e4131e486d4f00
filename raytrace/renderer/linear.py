"""Linear (HDR) image files: the float32 radiance before clamping and the
sRGB curve, as pbrt and Mitsuba users keep it.

- ``.npy``: NumPy's own format, (h, w, 3) float32, or an AOV's own dtype.
- ``.pfm``: Portable Float Map (little-endian, rows bottom to top, as the
  format says), read by most HDR tools.
- ``.exr``: OpenEXR, through the OpenEXR project's own Python wheels (the
  ``exr`` extra), ZIP-compressed float32.

AOVs follow the image's format, one file per buffer (``teapot.depth.pfm``);
PFM and EXR hold float32 only, so the integer buffers (primid, cost) are
stored as float32 there, exact up to 2**24.
"""
import os
import tempfile
from pathlib import Path

import numpy as np

from raytrace.errors import RaytraceError

LINEAR_FORMATS = (".npy", ".pfm", ".exr")
EXR_HINT = "pip install 'raytrace[exr]' (OpenEXR's wheels)"


def is_linear(path):
    return path is not None and Path(str(path)).suffix.lower() in LINEAR_FORMATS


def check_available(path):
    """RaytraceError before any work if ``path``'s format cannot be written here."""
    if Path(str(path)).suffix.lower() == ".exr":
        try:
            import OpenEXR  # noqa: F401
        except ImportError:
            raise RaytraceError(f"{path}: writing .exr needs OpenEXR: {EXR_HINT}") from None


def aov_paths(image_path, names):
    """teapot.pfm -> {"depth": teapot.depth.pfm, ...}: each AOV beside the image."""
    p = Path(image_path)
    return {name: p.with_name(f"{p.stem}.{name}{p.suffix}") for name in names}


def writer(array, path):
    """A writer(fileobj) of ``array`` ((h, w, 3) or (h, w)) in ``path``'s format."""
    ext = Path(str(path)).suffix.lower()
    if ext == ".npy":
        return lambda fh: np.save(fh, np.ascontiguousarray(array))
    data = np.ascontiguousarray(array, dtype=np.float32)
    if ext == ".pfm":
        return lambda fh: write_pfm(fh, data)
    if ext == ".exr":
        return lambda fh: _write_exr(fh, data)
    raise RaytraceError(f"{path}: not a linear image format (choose from {', '.join(LINEAR_FORMATS)})")


def write_pfm(fh, data):
    """PFM: 'PF' (RGB) or 'Pf' (grey), size, a negative scale for
    little-endian, then float32 rows from the bottom one up."""
    if data.ndim == 3 and data.shape[2] != 3:
        raise RaytraceError(f"PFM holds 1 or 3 channels, not {data.shape[2]}")
    h, w = data.shape[:2]
    fh.write(b"PF\n" if data.ndim == 3 else b"Pf\n")
    fh.write(f"{w} {h}\n-1.0\n".encode())
    fh.write(data[::-1].astype("<f4").tobytes())


def read_pfm(path):
    """A PFM file as float32 (h, w, 3) or (h, w), top row first."""
    with open(path, "rb") as fh:
        kind = fh.readline().strip()
        w, h = (int(x) for x in fh.readline().split())
        scale = float(fh.readline())
        data = np.frombuffer(fh.read(), dtype="<f4" if scale < 0 else ">f4")
    shape = (h, w, 3) if kind == b"PF" else (h, w)
    return data.reshape(shape)[::-1].astype(np.float32)


def _write_exr(fh, data):
    import OpenEXR
    channels = {"RGB": data} if data.ndim == 3 else {"Y": data}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    # OpenEXR writes to a named file: a private one, copied into the output's.
    fd, tmp = tempfile.mkstemp(suffix=".exr")
    os.close(fd)
    try:
        with OpenEXR.File(header, channels) as exr:
            exr.write(tmp)
        with open(tmp, "rb") as src:
            fh.write(src.read())
    finally:
        os.unlink(tmp)
