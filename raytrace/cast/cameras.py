"""Camera rays as Open3D makes them: a pinhole from a field of view, or
from intrinsic and extrinsic matrices, (height, width, 6)."""
import numpy as np

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import MAX_COORD

# Float64s a pixel at the peak: the (h, w, 6) rays, and while they are
# filled mgrid's two index arrays, the pixel grid (3) and its product (3).
BYTES_PER_PIXEL = 8 * (6 + 2 + 3 + 3)


def create_rays_pinhole(fov, center, eye, up, width, height):
    """Rays of a pinhole camera at ``eye`` looking at ``center``, Open3D's
    convention: ``fov`` is the horizontal field of view in degrees, the
    principal point the image centre, one ray through each pixel centre
    (x + 0.5, y + 0.5), directions not normalised (unit depth along the
    view axis, so t is depth).  Returns an (height, width, 6) float64 array
    of (origin, direction) rows; ``rays[..., :3]`` and ``rays[..., 3:]``
    go straight into ``cast_rays``.  As in Open3D, the camera's x axis is
    up x forward and its y axis ``up``, so row 0 looks along -up and column
    0 along +(forward x up): the picture is half a turn from a photograph's
    (``image[::-1, ::-1]`` shows it upright)."""
    width, height = _pixels(width, height)
    fov = _number("fov", fov)
    if not 0.0 < fov < 180.0:
        raise RaytraceError(f"fov: must be between 0 and 180 degrees, got {fov}")
    eye, center, up = (_vector(n, x) for n, x in (("eye", eye), ("center", center), ("up", up)))
    fwd = center - eye
    if not np.linalg.norm(fwd) > 0:
        raise RaytraceError("center: must differ from eye")
    fwd /= np.linalg.norm(fwd)
    right = np.cross(up, fwd)
    if not np.linalg.norm(right) > 1e-12 * np.linalg.norm(up):
        raise RaytraceError("up: must not be parallel to the view direction (center - eye)")
    right /= np.linalg.norm(right)
    true_up = np.cross(fwd, right)
    focal = 0.5 * width / np.tan(np.radians(fov) / 2.0)
    intrinsic = np.array([[focal, 0.0, 0.5 * width], [0.0, focal, 0.5 * height], [0.0, 0.0, 1.0]])
    rotation = np.stack([right, true_up, fwd])         # world -> camera
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation
    extrinsic[:3, 3] = -rotation @ eye
    return create_rays_from_matrices(intrinsic, extrinsic, width, height)


def create_rays_from_matrices(intrinsic, extrinsic, width, height):
    """Rays of a pinhole camera given as a 3x3 intrinsic matrix K and a 4x4
    world-to-camera extrinsic matrix [R | t] (Open3D's and OpenCV's
    convention): the ray through pixel centre (x + 0.5, y + 0.5) starts at
    the camera centre -R^T t with direction R^T K^-1 (x + 0.5, y + 0.5, 1).
    Returns an (height, width, 6) float64 array."""
    width, height = _pixels(width, height)
    k = _matrix("intrinsic", intrinsic, (3, 3))
    e = _matrix("extrinsic", extrinsic, (4, 4))
    try:
        k_inv = np.linalg.inv(k)
    except np.linalg.LinAlgError:
        raise RaytraceError("intrinsic: the matrix is singular") from None
    r, t = e[:3, :3], e[:3, 3]
    ys, xs = np.mgrid[0:height, 0:width]
    pix = np.stack([xs + 0.5, ys + 0.5, np.ones_like(xs, dtype=float)], axis=-1)
    rays = np.empty((height, width, 6))
    rays[..., :3] = -r.T @ t
    rays[..., 3:] = pix @ (r.T @ k_inv).T
    return rays


def _pixels(width, height):
    """(width, height) as ints, checked, and refused before anything is
    allocated if their rays would not fit in free memory."""
    out = []
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 1 << 16:
            raise RaytraceError(f"{name}: must be an integer from 1 to 65536, got {v!r}")
        out.append(int(v))
    from raytrace.scene.formats.mesh import available_memory
    need, free = out[0] * out[1] * BYTES_PER_PIXEL, available_memory()
    if need > free:
        raise RaytraceError(f"{out[0]}x{out[1]} rays need about {need / 2**30:.1f} GiB of memory "
                            f"while they are made, more than the {free / 2**30:.1f} GiB available")
    return out


def _number(name, v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise RaytraceError(f"{name}: must be a number, got {v!r}") from None
    if not np.isfinite(x):
        raise RaytraceError(f"{name}: must be finite, got {x}")
    return x


def _vector(name, v):
    a = _matrix(name, v, (3,))
    if not np.abs(a).max() <= MAX_COORD:
        raise RaytraceError(f"{name}: a value beyond {MAX_COORD:g}")
    return a


def _matrix(name, v, shape):
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise RaytraceError(f"{name}: must be numbers of shape {shape}") from None
    if a.shape != shape:
        raise RaytraceError(f"{name}: expected shape {shape}, got {a.shape}")
    if not np.isfinite(a).all():
        raise RaytraceError(f"{name}: NaN or infinite value")
    return a
