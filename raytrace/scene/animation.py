"""Camera paths for animations: a turntable orbit, or a scene file's
[animation] keyframes.  Plain Python: one Camera per frame, rendered like
any still."""
import math
from dataclasses import dataclass, replace
from numbers import Integral

from raytrace.errors import RaytraceError

MAX_FRAMES = 100_000   # a bound on a typo (frames = 1e9), far past any real animation


@dataclass(frozen=True)
class Key:
    """The camera at one frame of a keyframed path; fov None: the [camera]'s."""
    frame: int
    position: tuple
    look_at: tuple
    fov: float = None


@dataclass(frozen=True)
class Animation:
    """A scene file's [animation] table: ``frames`` frames, keys in
    strictly increasing frame order (at least one)."""
    frames: int
    keys: tuple


def check_frame_count(n, what="turntable"):
    """n as an int, or a RaytraceError: an integer from 1 to MAX_FRAMES."""
    if isinstance(n, bool) or not isinstance(n, Integral) or not 1 <= n <= MAX_FRAMES:
        raise RaytraceError(f"{what} must be an integer number of frames from 1 to {MAX_FRAMES}, "
                            f"got {n!r}")
    return int(n)


def _quarter_cos_sin(k, n):
    """cos and sin of 2*pi*k/n; exact on quarter turns, so a 4-frame
    turntable looks exactly along the axes."""
    if (4 * k) % n == 0:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[(4 * k // n) % 4]
    a = 2.0 * math.pi * k / n
    return math.cos(a), math.sin(a)


def turntable(camera, n):
    """n Cameras orbiting ``camera.look_at``: the eye turns 360*k/n degrees
    (k = 0..n-1) about the axis through look_at along ``camera.up``,
    counter-clockwise seen from above (from the up side, looking down the
    axis), so the scene seems to turn clockwise.  Frame 0 is ``camera``
    itself (an equal copy), so it renders exactly as the still; fov, up,
    width and height are kept."""
    n = check_frame_count(n)
    ux, uy, uz = (float(c) for c in camera.up)
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    if not (math.isfinite(norm) and norm > 0.0):
        raise RaytraceError(f"turntable: camera up must be a finite non-zero vector, got {camera.up!r}")
    kx, ky, kz = ux / norm, uy / norm, uz / norm
    cx, cy, cz = (float(c) for c in camera.look_at)
    vx, vy, vz = (float(e) - c for e, c in zip(camera.eye, (cx, cy, cz)))
    # Rodrigues: v cos a + (k x v) sin a + k (k . v)(1 - cos a), k the unit axis.
    wx, wy, wz = ky * vz - kz * vy, kz * vx - kx * vz, kx * vy - ky * vx
    along = kx * vx + ky * vy + kz * vz
    cams = [replace(camera)]
    for k in range(1, n):
        c, s = _quarter_cos_sin(k, n)
        eye = (cx + vx * c + wx * s + kx * along * (1.0 - c),
               cy + vy * c + wy * s + ky * along * (1.0 - c),
               cz + vz * c + wz * s + kz * along * (1.0 - c))
        cams.append(replace(camera, eye=eye))
    return cams


def _lerp(a, b, t):
    return tuple(x + (y - x) * t for x, y in zip(a, b))


def key_values(animation, fov):
    """(position, look_at, fov) for every frame: the keys' values, linear in
    frame index between keys, held before the first and after the last.
    ``fov`` stands for a key without its own."""
    keys = animation.keys
    out = []
    j = 0   # keys[j] is the last key at or before the frame, if there is one
    for f in range(animation.frames):
        while j + 1 < len(keys) and keys[j + 1].frame <= f:
            j += 1
        a = keys[j]
        fa = fov if a.fov is None else a.fov
        if f <= a.frame or j + 1 == len(keys):
            # A key's own frame and the holds take its values as they are.
            out.append((tuple(a.position), tuple(a.look_at), fa))
            continue
        b = keys[j + 1]
        fb = fov if b.fov is None else b.fov
        t = (f - a.frame) / (b.frame - a.frame)
        out.append((_lerp(a.position, b.position, t), _lerp(a.look_at, b.look_at, t),
                    fa + (fb - fa) * t))
    return out


def keyframe_path(camera, animation):
    """``animation.frames`` Cameras along the keys (see ``key_values``); up,
    width and height, and the fov of a key without one, are ``camera``'s."""
    return [replace(camera, eye=eye, look_at=look_at, fov=fov)
            for eye, look_at, fov in key_values(animation, camera.fov)]


def camera_path(scene, turntable=None):
    """The Cameras of an animation of ``scene``: a turntable of that many
    frames if ``turntable`` is given, else the scene's [animation] keys."""
    if turntable is not None:
        return _turntable(scene.camera, turntable)
    if getattr(scene, "animation", None) is None:
        raise RaytraceError(f"scene {scene.name!r} has no [animation] table; give --turntable N")
    return keyframe_path(scene.camera, scene.animation)


_turntable = turntable   # camera_path's argument hides the function's name


def view_problem(eye, look_at, up):
    """What is wrong with a camera looking from ``eye`` at ``look_at`` with
    ``up``, or None: ("look_at", ...) if they meet, ("up", ...) if up lies
    along the view."""
    view = [b - a for a, b in zip(eye, look_at)]
    if not any(view):
        return "look_at", "must differ from position"
    cross = (view[1] * up[2] - view[2] * up[1], view[2] * up[0] - view[0] * up[2],
             view[0] * up[1] - view[1] * up[0])
    if not math.hypot(*cross) > 1e-12 * math.hypot(*view) * math.hypot(*up):
        return "up", "parallel to the view direction (position to look_at)"
    return None

