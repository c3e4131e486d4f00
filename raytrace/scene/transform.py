"""Placing a mesh: scale, then rotate, then translate."""
import math

import numpy as np


def rotation(degrees_xyz):
    """Rotation by the given angles about the fixed x, y and z axes, in that
    order (x first): R = Rz @ Ry @ Rx, right-handed, degrees."""
    ax, ay, az = (math.radians(a) for a in degrees_xyz)
    cx, sx, cy, sy, cz, sz = (math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay),
                              math.cos(az), math.sin(az))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def transform_mesh(vertices, normals, translate=(0, 0, 0), rotate=(0, 0, 0), scale=(1, 1, 1)):
    """(vertices, normals) moved by p -> R S p + t.  Normals (or None) go
    through the inverse transpose, so they stay perpendicular under a
    non-uniform scale; the flattener renormalises them."""
    m = rotation(rotate) @ np.diag(np.asarray(scale, dtype=np.float64))
    v = np.asarray(vertices, dtype=np.float64) @ m.T + np.asarray(translate, dtype=np.float64)
    n = None if normals is None else np.asarray(normals, dtype=np.float64) @ np.linalg.inv(m)
    return v, n
