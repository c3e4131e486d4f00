"""The textbook first BVH builder: split each node at the median centroid
along the axis where centroids spread widest (pbrt's SplitMethod::Middle
and ::EqualCounts are its cousins).  Cheap to build, blind to empty space."""
import numpy as np

from raytrace.accel.bvh.topdown import RULE_MEDIAN, build_topdown


def build_binary(lo, hi, leaf_size):
    n = len(lo)
    return build_topdown(lo, hi, np.arange(n, dtype=np.int64), np.zeros(n, np.int64),
                         RULE_MEDIAN, leaf_size)
