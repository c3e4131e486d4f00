"""The acceleration structures: one entry each, read by the CLI, the
driver, the ray-casting API, the bench and the tests (pbrt-v4's
CreateAccelerator).

A structure ``x`` is two modules and the line below:
``raytrace/accel/x.py`` defines its layout (a namedtuple class),
``build(geo, obj_ranges)``, ``statistics(layout, n_prims)`` and, to be drawn
(--show-structure), ``outline(layout, depth)``, and to count every hit
on a layout of its own, ``for_counting(layout, geo)``;
``raytrace/kernels/x.py`` its traversal, registered for the layout
(kernels/query.py).  Nothing is imported, built
or compiled for a structure the run does not use.
"""
import functools
import importlib
import time
from dataclasses import dataclass

from .errors import OptionError, RaytraceError


@dataclass(frozen=True)
class Structure:
    name: str
    summary: str                  # one line, for --help and the README
    module: str                   # raytrace.accel.<module> and raytrace.kernels.<module>
    visit_counter: str = None     # its own counter, if any (stats.COUNTERS)
    visit_metric: str = None      # that counter per ray (stats.derive), a bench column

    def load(self, n_prims=0, **options):
        """Seconds spent loading (or compiling) the builder: a build of a
        few primitives, so the timed build() that follows measures building
        alone.  Builders are compiled per argument type, never per size, so
        the tiny scene loads everything the real one uses, but for a
        builder's code for big scenes (``load_big(n_prims, **options)`` in
        its module, if it has one: the n_prims of the scene to come)."""
        t0 = time.perf_counter()
        self.build(*_tiny_scene(), **options)
        builder = importlib.import_module(f"raytrace.accel.{self.module}")
        if hasattr(builder, "load_big"):
            builder.load_big(n_prims, **options)
        return time.perf_counter() - t0

    def build(self, geo, obj_ranges, **options):
        """(layout, build seconds); also loads the traversal for the layout.
        options: the build options (bvh_build, leaf_size, grid_density); a
        structure takes those it knows."""
        builder = importlib.import_module(f"raytrace.accel.{self.module}")
        importlib.import_module(f"raytrace.kernels.{self.module}")
        t0 = time.perf_counter()
        layout = builder.build(geo, obj_ranges, **options)
        return layout, time.perf_counter() - t0

    def counting_layout(self, layout, geo):
        """The layout that counts and lists every hit: what the accel
        module's ``for_counting(layout, geo)`` makes, if it has one (the
        BVH's: a tree built for counting, its triangles in leaf order), else
        ``layout``."""
        builder = importlib.import_module(f"raytrace.accel.{self.module}")
        make = getattr(builder, "for_counting", None)
        return layout if make is None else make(layout, geo)

    def check_outline(self):
        """RaytraceError unless the structure can be drawn (outline)."""
        if not hasattr(importlib.import_module(f"raytrace.accel.{self.module}"), "outline"):
            raise OptionError(f"{self.name} ({self.summary}) has no structure to show")

    def outline(self, layout, depth):
        """(lo, hi, level) arrays of the structure's boxes down to ``depth``,
        for drawing over the image (raytrace/overlay.py)."""
        self.check_outline()
        return importlib.import_module(f"raytrace.accel.{self.module}").outline(layout, depth)

    def statistics(self, layout, n_prims):
        """The structure's own figures (nodes, leaves, depth, memory, ...)."""
        return importlib.import_module(f"raytrace.accel.{self.module}").statistics(layout, n_prims)


STRUCTURES = {s.name: s for s in (
    Structure("none", "brute force: every primitive for every ray", "brute"),
    Structure("bvol", "a bounding box per object, then its primitives", "bvol"),
    Structure("bvh", "4-wide bounding volume hierarchy, binned SAH build", "bvh",
              "nodes_visited", "nodes_per_ray"),
    Structure("grid", "uniform grid walked by 3D-DDA", "grid",
              "cells_visited", "cells_per_ray"),
    Structure("kdtree", "kd-tree, binned SAH build, front-to-back traversal", "kdtree",
              "nodes_visited", "nodes_per_ray"),
)}
DEFAULT = "bvh"


def get(name):
    """The Structure called ``name``; RaytraceError naming the choices otherwise."""
    if not isinstance(name, str) or name not in STRUCTURES:
        raise RaytraceError(f"unknown acceleration structure {name!r} "
                            f"(choose from {', '.join(STRUCTURES)})")
    return STRUCTURES[name]


@functools.cache
def _tiny_scene():
    """(geometry, object ranges) of eight triangles, a sphere and a plane."""
    import numpy as np

    from .flatten import flatten
    from .scene import Camera, Mesh, Plane, Scene, Sphere
    grid = np.array([(x, y, 0.0) for y in range(3) for x in range(3)], dtype=float)
    quads = [(y * 3 + x, y * 3 + x + 1, y * 3 + x + 4, y * 3 + x + 3)
             for y in range(2) for x in range(2)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    scene = Scene("tiny", Camera((1, 1, 5), (1, 1, 0)),
                  [Mesh(grid, faces), Sphere((1, 1, 1), 0.5), Plane((0, -1, 0), (0, 1, 0))])
    geo, ranges, _ = flatten(scene)
    return geo, ranges


def build_structure(name, geo, obj_ranges, **options):
    """Returns (layout, build seconds) for structure ``name``."""
    return get(name).build(geo, obj_ranges, **options)
