"""What cast/ahead.py compiles ahead of a first query's build: one ray query
kernel, for a structure's empty layout and a one-triangle scene's geometry
(the types of any RayScene's), in the second process or in this one; or,
in the second process, the structure's builder, on that scene.

    python -m raytrace.cast.precompile ACCEL QUERY PACKETS [LARGE]
    (QUERY closest, occluded, count, list or points; PACKETS 1 for closest
    and any-hit calls of PACKET_MIN rays or more; or QUERY builder: the
    structure's builder, and a BVH's for counting, on that scene; LARGE 1:
    then cast/ordering.py's kernels, for a call of ORDER_MIN rays or more)
"""
import sys

import numpy as np


def main(accel, query, packets):
    from raytrace.accel.registry import get
    from raytrace.cast.prepared import query_geometry
    from raytrace.kernels import cast
    from raytrace.scene.model import Mesh
    mesh = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    geo, obj_ranges = query_geometry([mesh])[:2]
    rows, ends = np.zeros((0, 3)), np.zeros(0)
    cnt, clock = np.zeros((1, cast.COLUMNS), np.int64), np.zeros(1, np.int64)
    index = np.zeros(0, np.int64)
    if query == "builder":                 # the structure's, and a BVH's counting tree's
        structure = get(accel)
        layout, _ = structure.build(geo, obj_ranges)
        structure.counting_layout(layout, geo)
        return
    if query == "points":                  # a BVH's walk, whatever the structure
        from raytrace.accel.bvh.points import closest_points
        closest_points(cast.ray_scene(geo, get("bvh").empty_layout()), rows, np.zeros((0, 3)),
                       index, ends, ends, ends, 1, clock)
        return
    if query == "count":
        cast.cast_counts(cast.ray_scene(geo, get(accel).empty_counting_layout()), rows, rows, ends,
                         ends, index, cnt, clock)
        return
    if query == "list":
        cast.cast_listing(cast.ray_scene(geo, get(accel).empty_counting_layout()),
                          (rows, rows, ends, ends),
                          np.zeros(1, np.int64), False, 1, (ends, index, ends, ends), index, cnt,
                          np.zeros(2, np.int64))
        return
    acc = get(accel).empty_layout()
    n_rays = cast.PACKET_MIN if packets else 1        # the call's size picks its kernel
    if query == "closest":
        block = cast.closest_block(acc, n_rays)
        out = (np.zeros(0), np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    else:
        block = cast.occluded_block(acc, n_rays)
        out = np.zeros(0, np.bool_)
    cast.run_blocks(block, (cast.ray_scene(geo, acc), *cast.kernel_rays(rows, rows, ends, ends), out),
                    cnt, clock)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] == "1")
    if sys.argv[4:] == ["1"]:
        from raytrace.cast import ordering
        ordering.warm((np.float64,))     # float32 rays compile theirs at their first call
    from raytrace.kernels.ahead import finish
    finish()
