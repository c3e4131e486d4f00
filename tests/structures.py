"""The acceleration structures this build constructs, found at import time.

Tests parametrize over STRUCTURES instead of a hand-written list, so a
structure that lands later (the BVH) is covered by the same tests the day
it is merged, and one that is not built yet is left out rather than
skipped.  Only a structure refusing with "not available in this build" is
left out; any other error fails the import, loudly.
"""
import numpy as np

from raytrace.accel import build_accel
from raytrace.buffers import ACCEL_NAMES
from raytrace.driver import check_accel_built
from raytrace.errors import RaytraceError
from raytrace.flatten import flatten
from raytrace.scene import Camera, Mesh, Scene


def available_structures():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    probe = Scene("probe", Camera((0, 0, 1), (0, 0, 0)), [Mesh(v, np.array([[0, 1, 2]]))])
    geo, ranges, _ = flatten(probe)
    names = []
    for name in ACCEL_NAMES:
        try:
            acc, _ = build_accel(name, geo, ranges)
            check_accel_built(name, geo, acc)
        except RaytraceError as exc:
            if "not available in this build" not in str(exc):
                raise
            continue
        names.append(name)
    return names


STRUCTURES = available_structures()
