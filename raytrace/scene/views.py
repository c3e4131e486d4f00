"""Names for framing a mesh: up axes and views (no NumPy, so the command
line's --help can list them without importing it)."""
import math

UP_AXES = ("y", "z", "x", "-y", "-z", "-x")
# (azimuth, elevation) in degrees: azimuth turns from the front towards the
# right about the up axis, elevation rises towards up.
VIEWS = {
    "front": (0.0, 0.0),
    "right": (90.0, 0.0),
    "back": (180.0, 0.0),
    "left": (-90.0, 0.0),
    "top": (0.0, 90.0),
    "bottom": (0.0, -90.0),
    # the isometric direction (1, 1, 1): 45 degrees round, atan(1/sqrt 2) up
    "iso": (45.0, math.degrees(math.atan(1 / math.sqrt(2)))),
}
DEFAULT_VIEW = "iso"
