"""The BVH's entry points for the registry (accel/registry.py): ``build``
from a scene's geometry with a chosen builder (sah.py, median.py,
lbvh.py), then the collapse to 4 children (collapse.py); ``for_counting``,
``statistics`` and ``outline`` from their modules."""

import numba
import numpy as np

from raytrace.accel.bvh.box8 import LANES
from raytrace.accel.bvh.boxes import box_bound, box_bounds, box_bounds_kernel, outward
from raytrace.accel.bvh.collapse import collapse_bvh4
from raytrace.accel.bvh.counting import counting_copy
from raytrace.accel.bvh.layout import (
    BOX,
    BVH,
    COUNT_LEAF,
    COUNT_TRAVERSAL_COST,
    MAX_LEAF,
    PARALLEL_MIN,
    SPHERE_TRAVERSAL_COST,
    TRAVERSAL_COST,
    WIDTH,
    lane_entries,
)
from raytrace.accel.bvh.sah import build_bvh, build_bvh_parallel
from raytrace.accel.bvh.stats import outline, statistics  # noqa: F401  (the registry's)
from raytrace.kernels.buffers import n_bounded, prim_bounds
from raytrace.kernels.pages import trim_heap


def _parallel_threads(n_prims, bvh_build):
    """Threads for build_bvh_parallel and box_bounds: Numba's, for the SAH
    builder from PARALLEL_MIN primitives on and with more than one; else 0."""
    threads = numba.get_num_threads()
    big = BUILDERS[bvh_build] is None and n_prims >= PARALLEL_MIN
    return threads if big and threads > 1 else 0


def load_big(n_prims, bvh_build="sah", **_):
    """Load (or compile) box_bounds_kernel if a scene of n_prims primitives
    will use it (Structure.load: compile time is not build time)."""
    if _parallel_threads(n_prims, bvh_build):
        rows = np.zeros((0, 3))
        box_bounds_kernel(rows, rows, rows, rows, np.zeros(0), 0, 0, np.empty((0, LANES), BOX))


BUILDERS = {"sah": None, "median": "raytrace.accel.bvh.median", "lbvh": "raytrace.accel.bvh.lbvh"}


def build(geo, obj_ranges, bvh_build="sah", leaf_size=MAX_LEAF, traversal_cost=None, **_):
    """A BVH over every bounded primitive (planes have no box and are tested
    separately by every structure), built by ``bvh_build`` with leaves of at
    most ``leaf_size`` primitives, collapsed to 4 children per node.  The
    SAH builder weighs a node visit as ``traversal_cost`` primitive tests
    (by default the scene's: scene_traversal_cost)."""
    if traversal_cost is None:
        traversal_cost = scene_traversal_cost(geo)
    links = None
    threads = _parallel_threads(n_bounded(geo), bvh_build)
    if threads:
        boxes = box_bounds(geo, threads)
        *binary, links = build_bvh_parallel(boxes, int(leaf_size), threads,
                                            traversal_cost=traversal_cost)
        del boxes   # the boxes go before the wide tree is made: 32 bytes a primitive
    else:
        lo, hi = outward(*prim_bounds(geo))   # the float64 boxes go at once
        if BUILDERS[bvh_build] is None:
            binary = build_bvh(lo, hi, leaf_size, traversal_cost)
        else:
            import importlib
            binary = importlib.import_module(BUILDERS[bvh_build]).build_binary(lo, hi,
                                                                               int(leaf_size))
        del lo, hi
    node_lo, node_hi, node_start, node_count, prim_ids = binary
    del binary
    if len(prim_ids) >= PARALLEL_MIN:
        trim_heap()     # the build's freed scratch leaves before the wide tree, the peak
    node_box, node_child, node_count4 = collapse_bvh4(node_lo, node_hi, node_start, node_count,
                                                      links)
    return BVH(node_box=node_box, node_child=node_child, node_count=node_count4, prim_ids=prim_ids,
               box_bound=box_bound(node_box), lane_entry=lane_entries(node_child, node_count4),
               leaf_tris=leaf_corners(geo, prim_ids))


def scene_traversal_cost(geo):
    """A node visit weighed against the scene's mean primitive test: the
    harmonic mean of TRAVERSAL_COST over its triangles and
    SPHERE_TRAVERSAL_COST over its spheres (a visit costs 1, a triangle
    test 1 / TRAVERSAL_COST, a sphere test 1 / SPHERE_TRAVERSAL_COST)."""
    n_tri, n_sph = geo.tri_v0.shape[0], geo.sph_center.shape[0]
    if n_sph == 0:
        return TRAVERSAL_COST
    return (n_tri + n_sph) / (n_tri / TRAVERSAL_COST + n_sph / SPHERE_TRAVERSAL_COST)


def leaf_corners(geo, prim_ids):
    """The BVH's leaf_tris: the corners of the triangle in each slot of
    prim_ids, copied in leaf order (72 bytes a triangle)."""
    leaf_tris = np.full((9, len(prim_ids) + 3), np.nan)
    slots = np.flatnonzero(prim_ids < geo.tri_v0.shape[0])
    tris = prim_ids[slots]
    for corner, v in enumerate((geo.tri_v0, geo.tri_v1, geo.tri_v2)):
        for axis in range(3):
            leaf_tris[3 * corner + axis, slots] = v[tris, axis]
    return leaf_tris


def empty():
    """A layout of no primitives, of the built ones' types (cast/precompile.py)."""
    return BVH(node_box=np.zeros((0, 6, WIDTH), BOX), node_child=np.zeros((0, WIDTH), np.int64),
               node_count=np.zeros((0, WIDTH), np.int64), prim_ids=np.zeros(0, np.int64),
               box_bound=0.0, lane_entry=np.zeros((0, WIDTH), np.int64),
               leaf_tris=np.full((9, 3), np.nan))


def empty_counting():
    """for_counting's layout of no primitives (cast/precompile.py)."""
    return counting_copy(empty())


def for_counting(bvh, geo):
    """The CountingBVH of the scene whose tracing tree is ``bvh``: a tree of
    its own over the same primitives, built for counting (leaves of up to
    COUNT_LEAF, COUNT_TRAVERSAL_COST), made on a scene's first count or
    listing (cast/rayscene.py), never for a render.  The answers are the same on
    any tree (the tests are exact); ``bvh``'s builder and leaf size are
    not used."""
    tree = build(geo, None, leaf_size=COUNT_LEAF, traversal_cost=COUNT_TRAVERSAL_COST)
    return counting_copy(tree)
