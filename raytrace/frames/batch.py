"""Many frames, or one image in tiles: tasks of (camera, band of rows) run
in this process or on Dask workers (frames/distributed.py), with one Setup
(driver.prepare) shared by all of them.

A tile is a band of whole rows: the kernel's hashed random numbers depend
on the pixel, never on the order or the band, so an image assembled from
tiles is byte for byte the unsplit render.
"""
import os
import sys
import time
from dataclasses import dataclass

import numpy as np

from raytrace.renderer.driver import (
    base_stats,
    camera_buffer,
    integrator_of,
    prepare,
    render_band,
    to_srgb8,
    validate,
)


@dataclass
class Tile:
    frame: int
    y0: int
    y1: int
    image: np.ndarray            # (y1 - y0, width, 3) uint8 sRGB
    counters: np.ndarray         # (N_COUNTERS,) int64
    compile_s: float
    render_s: float
    worker: str


def render_tile(payload, threads, cam, frame, y0, y1):
    """One task: rows y0 .. y1 of a frame, as 8-bit sRGB (a quarter of the
    linear floats' bytes to send back).  Runs on a worker or in-process."""
    import numba

    from raytrace.kernels.jitconfig import KERNEL_LOCK
    with KERNEL_LOCK:                       # a Dask worker may run tasks on several threads
        if threads:
            numba.set_num_threads(threads)
        image, rows, t_compile, t_render = render_band(payload, cam, y0, y1,
                                                       threads or numba.get_num_threads())
    return Tile(frame=frame, y0=y0, y1=y1, image=to_srgb8(image), counters=rows.sum(axis=0),
                compile_s=t_compile, render_s=t_render, worker=_worker_name())


def _worker_name():
    # A Dask worker has imported distributed; this process need not (a
    # render here never imports Dask: its import is slow).
    distributed = sys.modules.get("distributed")
    if distributed is not None:
        try:
            return distributed.get_worker().address
        except ValueError:                # a client, not a worker
            pass
    return f"this process ({os.getpid()})"


def bands(height, tiles):
    """``tiles`` bands of whole strips of TILE rows (the renderer's unit of
    work, kernels/waves.py), as even as whole strips allow, the last cut at
    ``height``: [(y0, y1), ...].  So each band's rays go in the waves and
    packets the whole image's go in, and a tiled render counts what the
    still one counts (a packet's closest-hit counters depend on which rays
    travel together)."""
    from raytrace.kernels.wavefront import TILE
    strips = -(-height // TILE)
    tiles = max(1, min(int(tiles), strips))
    edges = [min(height, TILE * (strips * k // tiles)) for k in range(tiles + 1)]
    return list(zip(edges[:-1], edges[1:]))


class Tasks:
    """A render's tasks, (camera buffer, frame, y0, y1) for each band of
    rows of each frame not skipped, made as they are taken: a list made up
    front held frames x bands of them, with a camera buffer each, before the
    first tile rendered.  len() and ``tallest`` (a band's most rows) plan
    Dask's tasks without making them."""

    def __init__(self, cameras, frames, rows, width, height):
        self._cameras = cameras
        self._frames = frames
        self._size = (width, height)
        self.rows = rows
        self.tallest = max((y1 - y0 for y0, y1 in rows), default=0)

    def __len__(self):
        return len(self._frames) * len(self.rows)

    def __iter__(self):
        for f in self._frames:
            cam = camera_buffer(self._cameras[f], *self._size)     # one a frame, for all its bands
            for y0, y1 in self.rows:
                yield cam, f, y0, y1


class InProcess:
    """Runs tasks here, one after another, each on all the render threads."""
    workers = 1

    def __init__(self, threads):
        self.threads = threads

    def run(self, payload, tasks):
        for cam, frame, y0, y1 in tasks:
            yield render_tile(payload, self.threads, cam, frame, y0, y1)


class Tally:
    """Counters summed over tiles and frames; time per worker."""

    def __init__(self):
        self.counters = None
        self.workers = {}
        self.start = time.perf_counter()

    def add(self, tile):
        self.counters = tile.counters.copy() if self.counters is None else self.counters + tile.counters
        w = self.workers.setdefault(tile.worker, {"tiles": 0, "compile_s": 0.0, "render_s": 0.0})
        w["tiles"] += 1
        w["compile_s"] += tile.compile_s
        w["render_s"] += tile.render_s

    def stats(self, setup, scene_name, frames, tiles):
        from raytrace.renderer.stats import COUNTERS, derive
        wall = time.perf_counter() - self.start
        stats = base_stats(setup, scene_name)
        busy = max((w["compile_s"] + w["render_s"] for w in self.workers.values()), default=0.0)
        counters = self.counters if self.counters is not None else np.zeros(len(COUNTERS), np.int64)
        stats["frames"] = frames
        stats["tiles"] = tiles
        stats["time"] = {
            "render_s": sum(w["render_s"] for w in self.workers.values()),
            "build_s": setup.times["build_s"],
            "compile_s": setup.times["compile_s"]
            + sum(w["compile_s"] for w in self.workers.values()),
            "setup_s": setup.times["setup_s"],
            "wall_s": wall,
            # What the busiest worker's own work does not explain: scheduling,
            # transfer, waiting, and turning tiles into frames.
            "overhead_s": max(0.0, wall - busy),
        }
        stats["workers"] = self.workers
        from raytrace.renderer.driver import peak_memory_mb
        stats["peak_memory_mb"] = {**setup.peaks, "render": peak_memory_mb()}   # this process
        stats["counters"] = {key: int(counters[idx]) for key, _, _, idx in COUNTERS}
        return derive(stats)


def render_frames(scene, cameras, opts, runner=None, tiles=1, skip=(), on_frame=None):
    """Render one frame per camera; ``on_frame(index, image)`` receives each
    frame's uint8 image, in order.  Frames in ``skip`` are not rendered.
    ``runner``: InProcess (default) or distributed.DaskRunner.  Returns the
    statistics: counters summed over frames and tiles, time per worker."""
    from raytrace.renderer.firstrun import expecting_render
    with expecting_render(scene, opts):
        return _render_frames(scene, cameras, opts, runner, tiles, skip, on_frame)


def _render_frames(scene, cameras, opts, runner, tiles, skip, on_frame):
    validate(opts, scene)         # a bad option fails here, not on workers or a second process
    if getattr(runner, "warm", None) is not None:
        runner.warm(scene, opts)  # they compile or load while prepare flattens and builds
    elif integrator_of(opts, scene) == "whitted":
        from raytrace.renderer import ahead
        ahead.start(scene)        # a first run: the shading compiles beside prepare
    setup = prepare(scene, opts)
    runner = runner or InProcess(setup.threads)
    w, h = setup.width, setup.height
    rows = bands(h, tiles)
    tasks = Tasks(cameras, [f for f in range(len(cameras)) if f not in skip], rows, w, h)
    tally = Tally()
    pending = {}
    per_frame = len(rows)
    for tile in runner.run(setup.payload(), tasks):
        tally.add(tile)
        parts = pending.setdefault(tile.frame, [])
        parts.append(tile)
        if len(parts) == per_frame:        # tasks come back in order: the frame is whole
            image = np.concatenate([t.image for t in sorted(parts, key=lambda t: t.y0)])
            del pending[tile.frame]
            if on_frame is not None:
                on_frame(tile.frame, image)
    stats = tally.stats(setup, scene.name, len(cameras), per_frame)
    stats["time"]["scatter_s"] = getattr(runner, "scatter_s", 0.0)
    if getattr(runner, "warmed", None) is not None:
        # Compile/load, summed over processes as the tasks' is: the warm-up's
        # here (the builder) and on each worker (the render kernel).
        stats["time"]["compile_s"] += runner.warm_here_s
        # Every worker asked, a tile or not: one still warming at the end got none.
        for address, seconds in runner.warmed().items():
            stats["workers"].setdefault(address, {"tiles": 0, "compile_s": 0.0,
                                                  "render_s": 0.0})["warmup_s"] = seconds
            stats["time"]["compile_s"] += seconds or 0.0
    return stats


def render_tiled(scene, opts, runner=None, tiles=1):
    """One image in ``tiles`` bands (on ``runner``'s workers, or here, a
    band's floats at a time): a RenderResult without the linear image."""
    from raytrace.renderer.driver import RenderResult
    frames = []
    stats = render_frames(scene, [scene.camera], opts, runner, tiles,
                          on_frame=lambda i, image: frames.append(image))
    return RenderResult(image=frames[0], linear=None, stats=stats)


def animate(scene, cameras, opts, output=None, fps=24, resume=False, runner=None, tiles=1,
            progress=None):
    """Render a camera path: (frames, stats).  With ``output`` (.gif, .mp4
    or a PNG pattern, frames/writers.py) the frames are written there and not kept
    (frames is None); ``resume`` skips a PNG sequence's complete frames.
    ``progress(frames done, frames)`` after each frame."""
    n = len(cameras)
    done = [0]

    def advance():
        done[0] += 1
        if progress is not None:
            progress(done[0], n)

    if output is None:
        frames = [None] * n

        def keep(i, image):
            frames[i] = image
            advance()
        return frames, render_frames(scene, cameras, opts, runner, tiles, on_frame=keep)
    from raytrace.frames.writers import frame_output
    camera = getattr(scene, "camera", None)
    size = (opts.width if opts.width is not None else getattr(camera, "width", None),
            opts.height if opts.height is not None else getattr(camera, "height", None))
    with frame_output(output, n, fps=fps, resume=resume,
                      size=size if None not in size else None) as out:
        skip = {i for i in range(n) if out.complete(i)}
        done[0] = len(skip)

        def write(i, image):
            out.write(i, image)
            advance()
        stats = render_frames(scene, cameras, opts, runner, tiles, skip=skip, on_frame=write)
    stats["frames_skipped"] = len(skip)
    return None, stats
