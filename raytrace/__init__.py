"""raytrace: a fast, honest, teachable CPU ray tracer.

    >>> import raytrace
    >>> scene = raytrace.load_scene("teapot")             # or "model.obj", "scene.toml"
    >>> result = raytrace.render(scene, accel="bvol", width=320, height=240)
    >>> result.image.shape, result.stats["counters"]["primary_rays"]
    ((240, 320, 3), 76800)

``RayScene`` builds meshes or a scene once for your own ray queries with
the renderer's kernels; ``cast_rays`` and ``occluded`` do one batch.  Importing this package is cheap: NumPy,
Numba and trimesh are imported by the first call that needs them.
"""
from raytrace.errors import RaytraceError, RaytraceWarning

__all__ = ["load_scene", "render", "render_frames", "RayScene", "cast_rays", "occluded",
           "create_rays_pinhole", "create_rays_from_matrices", "RaytraceError", "RaytraceWarning"]
# Imported on first use, so that `import raytrace` stays light.
_LAZY = {"RayScene": "cast.rayscene", "create_rays_pinhole": "cast.cameras",
         "create_rays_from_matrices": "cast.cameras"}


def load_scene(name_or_path, **opts):
    """A Scene from a built-in name ("teapot", "spheres"), a mesh file
    (.obj, .ply, .stl, .off, .glb, .gltf: framed by an automatic camera, on a
    ground plane) or a TOML scene file.

    Options: detail (teapot), view / azimuth / elevation / up / crease /
    flat (mesh files), fov, width, height.  See raytrace.scene.load.load_scene.
    """
    from raytrace.scene.load import load_scene as _load
    return _load(name_or_path, **opts)


def render(scene, client=None, tiles=None, **options):
    """Render a Scene (or a name or path, loaded with load_scene) and return
    a RenderResult: ``image`` (h, w, 3) uint8 sRGB, ``linear`` float32,
    ``stats`` (times and counters, as the CLI's --json), ``aovs`` with
    aov=True (depth, normal, primid, cost); ``result.save("x.png")`` (or
    .npy, .pfm, .exr for the linear image), and Jupyter shows it.

    Options are the fields of raytrace.renderer.driver.RenderOptions: accel
    (a name in raytrace.accel.registry.STRUCTURES), shadows ("none", "hard", "soft"),
    light_samples, pattern, width, height, spp, seed, threads, aov.

    ``tiles=N`` renders the image as N bands of rows; ``client=`` (a
    dask.distributed Client) runs them on its workers (4 per worker by
    default).  The image is the same, byte for byte; ``linear`` and the
    AOVs then stay unassembled (None / not available).
    """
    scene = _scene(scene)
    tiles = _tiles(tiles)
    from raytrace.renderer.firstrun import RENDER_S, announce_if_cold
    accel = str(options.get("accel", "bvh"))
    announce_if_cold(f"{scene.name}: {accel}, {options.get('shadows', 'hard')} shadows",
                     RENDER_S.get(accel, 8))
    if client is None and tiles is None:
        from raytrace.renderer.driver import render as _render
        return _render(scene, **options)
    from raytrace.frames.batch import render_tiled
    from raytrace.renderer.driver import options_with
    opts = options_with(None, options)
    if opts.aov:
        raise RaytraceError("aov=True needs the whole image in this process: drop client and tiles")
    runner = _runner(client)
    return render_tiled(scene, opts, runner, tiles or (4 * runner.workers if runner else 1))


def render_frames(scene, cameras=None, turntable=None, output=None, fps=24, resume=False,
                  client=None, tiles=1, progress=None, **options):
    """Render a camera path: a list of Cameras, ``turntable=N`` frames
    orbiting the scene's camera, or the scene file's [animation].

    Returns (frames, stats): frames a list of (h, w, 3) uint8 images (a
    Frames: shown in a notebook, ``frames.save("spin.gif")``), or
    None when ``output`` (.gif, .mp4, or a PNG pattern like
    "frames/spin_%04d.png") received them; stats sum the counters over
    frames and give time per worker.  ``client``: a dask.distributed
    Client whose workers render the frames; ``progress(done, frames)``.
    """
    from raytrace.frames.batch import animate
    from raytrace.renderer.driver import options_with
    from raytrace.scene.animation import camera_path
    from raytrace.scene.model import Camera
    scene = _scene(scene)
    tiles = _tiles(tiles, 1)
    if progress is not None and not callable(progress):
        raise RaytraceError(f"progress must be a function (frames done, frames) or None, "
                            f"got {progress!r}")
    if cameras is None:
        cameras = camera_path(scene, turntable)
    elif turntable is not None:
        raise RaytraceError("give cameras or turntable, not both")
    else:
        if isinstance(cameras, (str, bytes)) or not hasattr(cameras, "__iter__"):
            raise RaytraceError(f"cameras: expected a list of Cameras, got {type(cameras).__name__}")
        cameras = list(cameras)
        for i, cam in enumerate(cameras):
            if not isinstance(cam, Camera):
                raise RaytraceError(f"cameras[{i}]: expected a Camera, got {type(cam).__name__}")
    if output is not None:
        from raytrace.frames.writers import check_frame_output
        check_frame_output(str(output), resume=resume)
    from raytrace.frames.shown import Frames
    opts = options_with(None, options)
    frames, stats = animate(scene, list(cameras), opts, output=None if output is None else str(output),
                            fps=fps, resume=resume, runner=_runner(client), tiles=tiles,
                            progress=progress)
    return (None if frames is None else Frames(frames)), stats


def _scene(scene):
    from pathlib import Path

    from raytrace.scene.model import Scene
    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    if not isinstance(scene, Scene):
        raise RaytraceError(f"scene: expected a Scene, a name or a path, got {type(scene).__name__}")
    return scene


def _runner(client):
    if client is None:
        return None
    if not all(hasattr(client, a) for a in ("submit", "scatter", "gather")):
        hint = " (connect first: distributed.Client(address))" if isinstance(client, str) else ""
        raise RaytraceError(f"client: expected a dask.distributed Client, got "
                            f"{type(client).__name__}{hint}")
    from raytrace.frames.distributed import DaskRunner
    return DaskRunner(client, None)


def _tiles(tiles, default=None):
    """tiles: None (``default``) or a whole number from 1 to 65536."""
    from numbers import Integral
    if tiles is None:
        return default
    if isinstance(tiles, bool) or not isinstance(tiles, Integral) or not 1 <= tiles <= 1 << 16:
        from raytrace.errors import OptionError
        raise OptionError(f"tiles must be an integer from 1 to 65536, got {tiles!r}")
    return int(tiles)


def cast_rays(target, origins, directions, accel="bvh", t_max=None):
    """Closest hits of rays against ``target``: a (vertices, faces) pair, a
    trimesh.Trimesh (anything with .vertices and .faces) or a Scene.

    Returns a RayHits with (n,) arrays t, prim_id, u, v, object_id (also
    ``hits["t"]``); t is in units of each direction's length, inf and -1
    on a miss.  See raytrace.cast.rayscene.cast_rays.
    """
    from raytrace.cast.rayscene import cast_rays as _cast
    return _cast(target, origins, directions, accel=accel, t_max=t_max)


def occluded(target, origins, directions, t_max, accel="bvh"):
    """(n,) booleans: is anything hit with 0 < t < t_max along each ray?
    See raytrace.cast.rayscene.occluded."""
    from raytrace.cast.rayscene import occluded as _occluded
    return _occluded(target, origins, directions, t_max, accel=accel)


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'raytrace' has no attribute {name!r}")
