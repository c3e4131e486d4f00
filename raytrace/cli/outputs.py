"""What a command writes, checked before it renders: image, linear and AOV
paths, frame sequences, the work options that go together; and writing
them."""

import click

from raytrace.errors import RaytraceError


def _write_outputs(result, output, aov, aov_out, heatmap, outputs):
    """Write the image, any AOVs and the heatmap as one commit (the Outputs
    ``outputs``: all or none); record them in the stats and return the lines
    that report them."""
    from raytrace.renderer import linear
    from raytrace.renderer.output import image_writer, npz_writer
    notes = []
    if linear.is_linear(output):
        outputs.add(output, linear.writer(result.linear, output))
    else:
        outputs.add(output, image_writer(result.image, output))
    result.stats["output"] = str(output)
    if isinstance(aov_out, dict):       # a linear image: one file per buffer, its format
        for name, path in aov_out.items():
            outputs.add(path, linear.writer(result.aovs[name], path))
        result.stats["aov"] = {"paths": {k: str(p) for k, p in aov_out.items()}, "buffers": list(aov)}
        notes.append(f"wrote {', '.join(str(p) for p in aov_out.values())}")
    elif aov_out is not None:
        outputs.add(aov_out, npz_writer({k: result.aovs[k] for k in aov}))
        result.stats["aov"] = {"path": str(aov_out), "buffers": list(aov)}
        notes.append(f"wrote {aov_out} ({', '.join(aov)})")
    if heatmap is not None:
        from raytrace.renderer.heatmap import cost_heatmap
        img, lo, hi = cost_heatmap(result.aovs["cost"])
        outputs.add(heatmap, image_writer(img, heatmap))
        result.stats["heatmap"] = {"path": str(heatmap), "cost_min": lo, "cost_max": hi}
        notes.append(f"wrote {heatmap} (box + primitive tests per pixel, log scale: "
                     f"{lo:,} = dark purple to {hi:,} = yellow)")
    return notes


def _is_file(path):
    """Whether ``path`` is a file; False for a name the system refuses (too long)."""
    from pathlib import Path
    try:
        return Path(path).is_file()
    except OSError:
        return False


def _aov_out(output, aov):
    """Where --aov goes: OUTPUT.aov.npz beside an 8-bit image; beside a
    linear one, a file per buffer in its format ({name: path})."""
    if not aov:
        return None
    from raytrace.renderer.linear import aov_paths, is_linear
    if is_linear(output):
        return aov_paths(output, aov)
    from raytrace.renderer.aov import aov_path
    return aov_path(output)


def _aov_files(aov_out):
    return list(aov_out.values()) if isinstance(aov_out, dict) else [aov_out]


def _check_linear(output, show_depth, work):
    """UsageError for what a linear (.npy, .pfm, .exr) output cannot go with."""
    from raytrace.renderer.linear import check_available
    if show_depth is not None:
        raise click.UsageError("--show-structure draws on the 8-bit image: write a .png")
    if work.tiles is not None or work.workers is not None or work.scheduler is not None:
        raise click.UsageError(f"{output}: a linear image needs the whole render in this process: "
                               "drop --tiles, --workers and --scheduler")
    try:
        check_available(output)
    except RaytraceError as exc:
        raise click.ClickException(str(exc)) from None


def _show_structure(result, scene, accel, depth):
    """The image with the structure's boxes down to ``depth`` drawn over it."""
    from raytrace.accel.registry import get
    from raytrace.renderer.driver import camera_buffer
    from raytrace.renderer.overlay import draw_outline
    lo, hi, level = get(accel).outline(result.structure, depth)
    h, w = result.image.shape[:2]
    result.stats["structure_shown"] = {"depth": depth, "boxes": int(len(lo))}
    return draw_outline(result.image, camera_buffer(scene.camera, w, h), lo, hi, level,
                        max(depth, int(level.max()) if len(level) else 0))


def _is_frame_path(path):
    """An output that holds frames: an animation file or a numbered PNG pattern."""
    return path is not None and (path.lower().endswith((".gif", ".mp4")) or _is_numbered(path))


def _is_numbered(path):
    """A name with a frame-number field, %d or %04d (frames/writers.py)."""
    from raytrace.frames.writers import number_fields
    return path is not None and bool(number_fields(path.rsplit("/", 1)[-1]))


def _check_work(animated, still_extras, work):
    """UsageError for the frame and work options (params.WorkArgs) that
    contradict each other."""
    fps, resume, tiles, workers, scheduler = (work.fps, work.resume, work.tiles, work.workers,
                                              work.scheduler)
    if workers is not None and scheduler is not None:
        raise click.UsageError("--workers starts a local cluster; --scheduler (or "
                               "DASK_SCHEDULER_ADDRESS) names a running one: give one")
    if workers is not None:
        from raytrace.frames.distributed import check_worker_count
        try:
            check_worker_count(workers)
        except RaytraceError as exc:
            raise click.UsageError(f"--workers: {exc}") from None
    if scheduler is not None:
        from raytrace.frames.dask_address import check_scheduler_address
        try:
            check_scheduler_address(scheduler)
        except RaytraceError as exc:
            raise click.UsageError(f"--scheduler: {exc}") from None
    if not animated:
        for flag, value in (("--fps", fps), ("--resume", resume or None)):
            if value is not None:
                raise click.UsageError(f"{flag} applies to frame sequences (--turntable, or -o "
                                       f"with .gif, .mp4 or a pattern like frames/f_%04d.png)")
    for flag in still_extras:
        if animated:
            raise click.UsageError(f"{flag} applies to still images")
        if tiles is not None or workers is not None or scheduler is not None:
            raise click.UsageError(f"{flag} needs the whole image in this process: "
                                   f"drop --tiles, --workers and --scheduler")


def _check_image_path(flag, path, linear=False):
    """UsageError for a path with no image format; ``linear``: also the
    float formats (.npy, .pfm, .exr) of raytrace/linear.py."""
    from pathlib import Path

    from raytrace.renderer.linear import LINEAR_FORMATS
    from raytrace.renderer.output import IMAGE_FORMATS
    formats = [*IMAGE_FORMATS, *(LINEAR_FORMATS if linear else ())]
    if path == "":
        raise click.UsageError(f"{flag}: empty file name")
    if path is not None and Path(path).suffix.lower() not in formats:
        raise click.UsageError(f"{flag}: {path}: unknown image format (use one of "
                               f"{', '.join(formats)})")
