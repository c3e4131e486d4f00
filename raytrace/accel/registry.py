"""The acceleration structures: one entry each, read by the CLI, the
driver, the ray-casting API, the bench and the tests (pbrt-v4's
CreateAccelerator).

A structure ``x`` is a folder, ``raytrace/accel/x/``, and a line below.
Its ``build.py`` defines ``build(geo, obj_ranges)`` (which returns its layout,
a namedtuple class), ``statistics(layout, n_prims)`` and, to be drawn
(--show-structure), ``outline(layout, depth)``, and to count every hit
on a layout of its own, ``for_counting(layout, geo)``; importing it
registers its traversal for the layout (kernels/query.py).  The registry
itself imports no structure: nothing is imported, built or compiled for a
structure the run does not use.
"""
import importlib
import time
from dataclasses import dataclass

from raytrace.errors import OptionError, RaytraceError


@dataclass(frozen=True)
class Structure:
    name: str
    summary: str                  # one line, for --help and the README
    module: str                   # its folder, raytrace/accel/<module>/
    visit_metric: str = None      # its own counter per ray, if any (stats.derive), a bench column
    build_options: tuple = ()     # the render options its build takes (raytrace/options.py)
    # Whether a run that compiles both its builder and its ray kernels
    # compiles the ray kernels in a second process meanwhile (renderer/ahead.py,
    # cast/ahead.py), where the stages or query kernels of another structure
    # are cached: worth a second process's start (about 1 s) only where the
    # builder compiles about as long as the ray kernels (the kd-tree's, 1.9 s
    # each here; `--accel kdtree` after a BVH teapot 4.2 -> 3.4 s, the grid's
    # 3.0 -> 3.7, docs/benchmarks.md).
    rays_ahead: bool = False
    # Whether its packet, counting and listing kernels compile longer than
    # its builder (the BVH's: 4, 5 and 3 s against 2), so a RayScene's
    # first such query compiles the kernel in this process and sends the
    # builder to the second (cast/ahead.py).
    long_query_kernels: bool = False

    def package(self):
        """The structure's build module, ``raytrace/accel/<module>/build.py``,
        imported on first use with its package (which registers the traversal)."""
        return importlib.import_module(f"raytrace.accel.{self.module}.build")

    def load(self, tiny, n_prims=0, **options):
        """Seconds spent loading (or compiling) the builder: a build of a
        few primitives (``tiny``: (geometry, object ranges), as
        scene.flatten.tiny_geometry makes), so the timed build() that follows
        measures building alone.  Builders are compiled per argument type, never per size, so
        the tiny scene loads everything the real one uses, but for a
        builder's code for big scenes (``load_big(n_prims, **options)`` in
        its module, if it has one: the n_prims of the scene to come)."""
        t0 = time.perf_counter()
        self.build(*tiny, **options)
        builder = self.package()
        if hasattr(builder, "load_big"):
            builder.load_big(n_prims, **options)
        return time.perf_counter() - t0

    def build(self, geo, obj_ranges, **options):
        """(layout, build seconds); also loads the traversal for the layout.
        options: the build options (bvh_build, leaf_size, grid_density); a
        structure takes those it knows."""
        builder = self.package()
        t0 = time.perf_counter()
        layout = builder.build(geo, obj_ranges, **options)
        return layout, time.perf_counter() - t0

    def first_rays_ahead(self):
        """Whether a run of this structure compiles its ray kernels in a
        second process beside its builder (``rays_ahead``) because its
        traversal is not in the kernel cache (a glob of its folder's,
        importing nothing of it)."""
        from raytrace.kernels.cachedir import traversal_cached
        return self.rays_ahead and not traversal_cached(self.module)

    def empty_layout(self):
        """A layout of no primitives, of the types a build's has, made
        without compiling the builder: a second process compiles a query
        kernel for it while this one builds (cast/ahead.py)."""
        return self.package().empty()

    def empty_counting_layout(self):
        """counting_layout's layout for empty_layout, made without building
        or compiling: the package's ``empty_counting()`` if it has one."""
        make = getattr(self.package(), "empty_counting", None)
        return self.empty_layout() if make is None else make()

    def counting_layout(self, layout, geo):
        """The layout that counts and lists every hit: what the accel
        module's ``for_counting(layout, geo)`` makes, if it has one (the
        BVH's: a tree built for counting, its triangles in leaf order), else
        ``layout``."""
        make = getattr(self.package(), "for_counting", None)
        return layout if make is None else make(layout, geo)

    def check_outline(self):
        """RaytraceError unless the structure can be drawn (outline)."""
        if not hasattr(self.package(), "outline"):
            raise OptionError(f"{self.name} ({self.summary}) has no structure to show")

    def outline(self, layout, depth):
        """(lo, hi, level) arrays of the structure's boxes down to ``depth``,
        for drawing over the image (raytrace/renderer/overlay.py)."""
        self.check_outline()
        return self.package().outline(layout, depth)

    def statistics(self, layout, n_prims):
        """The structure's own figures (nodes, leaves, depth, memory, ...)."""
        return self.package().statistics(layout, n_prims)


STRUCTURES = {s.name: s for s in (
    Structure("none", "brute force: every primitive for every ray", "brute"),
    Structure("bvol", "a bounding box per object, then its primitives", "bvol"),
    Structure("bvh", "4-wide bounding volume hierarchy, binned SAH build", "bvh",
              "nodes_per_ray", ("bvh_build", "leaf_size"), long_query_kernels=True),
    Structure("grid", "uniform grid walked by 3D-DDA", "grid", "cells_per_ray", ("grid_density",)),
    Structure("kdtree", "kd-tree, binned SAH build, front-to-back traversal", "kdtree",
              "nodes_per_ray", rays_ahead=True),
)}
DEFAULT = "bvh"
# Every structure's build options, each once, in registry order: what the
# driver passes to a build and reports in the statistics.
BUILD_OPTIONS = tuple(dict.fromkeys(o for s in STRUCTURES.values() for o in s.build_options))


def get(name):
    """The Structure called ``name``; RaytraceError naming the choices otherwise."""
    if not isinstance(name, str) or name not in STRUCTURES:
        raise RaytraceError(f"unknown acceleration structure {name!r} "
                            f"(choose from {', '.join(STRUCTURES)})")
    return STRUCTURES[name]


def build_structure(name, geo, obj_ranges, **options):
    """Returns (layout, build seconds) for structure ``name``."""
    return get(name).build(geo, obj_ranges, **options)
