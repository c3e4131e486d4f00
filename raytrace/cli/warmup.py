"""Compile kernels into the cache ahead of time (``raytrace warmup``): for
container images, CI, and machines that share one cache.

A render compiles the structure's ray kernels (its layout's type), and
the shading stages once per combination of textures (vertex colours or an
image) and mirrors or glass; every shadow mode shares them.  Each step
renders a tiny scene with exactly that combination, so the kernels a real
scene of that kind uses are the ones compiled (the types, not the sizes,
pick them).
"""
import itertools
import time
from dataclasses import dataclass

import numpy as np

from raytrace.scene.kinds import scene_kind, tiny_scene

FEATURES = ("textures", "mirrors", "path", "queries", "loading")


@dataclass
class Step:
    label: str
    run: object            # a function of no arguments


def _render(accel, shadows, textures, mirrors):
    from raytrace.renderer.driver import render
    return lambda: render(tiny_scene(textures, mirrors), accel=accel.split(":")[0],
                          bvh_build=accel.split(":")[1] if ":" in accel else "sah",
                          shadows=shadows, light_samples=4, pattern="stratified")


def _path(accel, textures):
    """The path tracer's stage (its own, whatever the structure; a textured
    scene's variant apart) and the structure's ray kernels it calls."""
    from raytrace.renderer.driver import render
    return lambda: render(tiny_scene(textures, True), accel=accel.split(":")[0],
                          integrator="path", spp=1)


def _queries(accel):
    def run():
        from raytrace.cast.rayscene import RayScene
        from raytrace.kernels.cast import PACKET_MIN
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
        f = np.array([[0, 1, 2], [0, 2, 3]])
        rays = RayScene(accel=accel)
        rays.add_mesh(v, f)
        # One ray, and PACKET_MIN: from there closest and any hit take the
        # rays in packets, kernels of their own.
        for n in (1, PACKET_MIN):
            o, d = np.tile([0.5, 0.5, 1.0], (n, 1)), np.tile([0.0, 0.0, -1.0], (n, 1))
            rays.cast_rays(o, d).normal                   # noqa: B018 -- computing it compiles
            rays.occluded(o, d)
            rays.count_intersections(o, d)
            rays.list_intersections(o, d)
            rays.contains(o)
            rays.distance(o)
        # Large calls of rays in an incoherent order are sorted first.
        from raytrace.cast import ordering
        ordering.warm()
    return run


def _loading():
    from raytrace.kernels.uncompiled import compiled_always
    from raytrace.scene.flatten import _kept_corners_parallel
    from raytrace.scene.formats.obj import warm_kernel
    from raytrace.scene.formats.polygons import polygon_lists
    from raytrace.scene.normals import crease_split
    from raytrace.scene.teapot import load_kernels
    load_kernels(256)                      # a big teapot's tessellation
    _kept_corners_parallel(np.zeros((1, 3)), np.zeros((3, 1), np.int64), 1)
    # Every mesh file: welding repeated positions and crease-angle normals
    # (scene/normals.py), with the same types as a file's arrays; compiled,
    # though a mesh this small would run them as Python.
    with compiled_always():
        crease_split(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
    # A binary PLY of mixed polygons: one triangle, a uchar count and int indices.
    record = np.array([3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0], np.uint8)
    polygon_lists(record, 1, 1, 4, True, False, np.empty(1, np.int64), np.empty(3, np.int64))
    warm_kernel()                          # an OBJ's lines


def _big_builders(accels):
    from raytrace.accel.registry import get
    from raytrace.scene.flatten import tiny_geometry

    def run():
        for accel in accels:
            name, _, build = accel.partition(":")
            get(name).load(tiny_geometry(), 10**8, bvh_build=build or "sah")   # big-scene paths too
    return run


def worker_payload(scene, opts):
    """(Payload, camera buffer) of the tiny scene with the render kernel's
    types that ``scene`` rendered with ``opts`` (RenderOptions) will have.
    A Dask worker renders an empty band of it before its first tile
    (frames/distributed.py): the kernel compiles or loads there while this
    process flattens the scene and builds its structure.  Only the render
    kernel: making the payload here loads the structure's builder, which
    the scene's build loads next anyway."""
    import dataclasses

    from raytrace.renderer.driver import camera_buffer, prepare
    tiny = tiny_scene(*scene_kind(scene))
    setup = prepare(tiny, dataclasses.replace(opts, width=None, height=None, progress=None,
                                              aov=False))
    return setup.payload(), camera_buffer(tiny.camera, setup.width, setup.height)


def plan(accels, shadows=("hard",), features=()):
    """The steps that compile ``accels`` (names as --accel, or
    "bvh:median", "bvh:lbvh") with the FEATURES asked for.  Every shadow
    mode in ``shadows`` shares the kernels: the first is rendered."""
    mode = "soft" if tuple(shadows) == ("soft",) else "hard"
    steps = []
    for accel, tex, mir in itertools.product(
            accels, (False, True) if "textures" in features else (False,),
            (False, True) if "mirrors" in features else (False,)):
        words = [accel] + ["textures"] * tex + ["mirrors and glass"] * mir
        steps.append(Step(f"render: {', '.join(words)}", _render(accel, mode, tex, mir)))
    if "path" in features:
        for accel, tex in itertools.product(dict.fromkeys(a.split(":")[0] for a in accels),
                                            (False, True) if "textures" in features else (False,)):
            steps.append(Step(f"path tracer: {accel}" + ", textures" * tex, _path(accel, tex)))
    steps.append(Step("builders for big scenes", _big_builders(accels)))
    if "queries" in features:
        steps += [Step(f"ray queries: {a}", _queries(a))
                  for a in dict.fromkeys(a.split(":")[0] for a in accels)]
    if "loading" in features:
        steps.append(Step("loading: big teapots and meshes", _loading))
    return steps


def run(steps, started=None, done=None):
    """Run the steps: ``started(k, n, label)`` before each and ``done(k, n,
    label, seconds)`` after.  Returns the seconds of each."""
    from raytrace.renderer.firstrun import set_quiet
    set_quiet(True)                  # the steps say what compiles
    times = []
    for k, step in enumerate(steps, 1):
        if started is not None:
            started(k, len(steps), step.label)
        t0 = time.perf_counter()
        step.run()
        times.append(time.perf_counter() - t0)
        if done is not None:
            done(k, len(steps), step.label, times[-1])
    return times
