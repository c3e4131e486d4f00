"""The second process of cast/ahead.py: compile one ray query kernel for a
structure's empty layout and a one-triangle scene's geometry (the types
of any RayScene's), and nothing else: no structure is built.

    python -m raytrace.cast.precompile ACCEL QUERY PACKETS
    (QUERY closest or occluded; PACKETS 1 for calls of PACKET_MIN rays or more)
"""
import sys

import numpy as np


def main(accel, query, packets):
    from raytrace.accel.registry import get
    from raytrace.cast.prepared import query_geometry
    from raytrace.kernels import cast
    from raytrace.scene.model import Mesh
    mesh = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    geo = query_geometry([mesh])[0]
    acc = get(accel).empty_layout()
    rows, ends = np.zeros((0, 3)), np.zeros(0)
    cnt, clock = np.zeros((1, cast.COLUMNS), np.int64), np.zeros(1, np.int64)
    n_rays = cast.PACKET_MIN if packets else 1        # the call's size picks its kernel
    if query == "closest":
        block = cast.closest_block(acc, n_rays)
        out = (np.zeros(0), np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    else:
        block = cast.occluded_block(acc, n_rays)
        out = np.zeros(0, np.bool_)
    block(geo, acc, rows, rows, ends, ends, out, cnt, np.empty(0, np.int64), clock)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] == "1")
