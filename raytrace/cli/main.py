"""Command line: ``raytrace SCENE [options]`` renders, ``raytrace scenes`` lists.

Bad arguments exit 2 (click's UsageError), bad input or runtime failures
exit 1 (ClickException); neither prints a traceback.
"""
import contextlib
import sys
import time

import click

from raytrace.cli.outputs import (
    _aov_files,
    _aov_out,
    _check_image_path,
    _check_linear,
    _check_work,
    _is_file,
    _is_frame_path,
    _is_numbered,
    _show_structure,
    _write_outputs,
)
from raytrace.cli.params import AovType, _render_options, _scene_options, _work_options, scene_kwargs
from raytrace.errors import OptionError, RaytraceError
from raytrace.options import BY_NAME
from raytrace.renderer import interrupt
from raytrace.renderer.interrupt import raise_if_interrupted


class DefaultRenderGroup(click.Group):
    """A group whose unknown first word is a scene: ``raytrace teapot ...``
    means ``raytrace render teapot ...``."""

    def parse_args(self, ctx, args):
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h", "--version"):
            args = ["render", *args]
        return super().parse_args(ctx, args)


@click.group(cls=DefaultRenderGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="raytrace")
def main():
    """raytrace: a fast, honest, teachable CPU ray tracer.

    \b
    raytrace teapot --shadows soft --no-bvol   render a built-in scene
    raytrace model.obj --view front            render a mesh file
    raytrace scene.toml                        render a scene file
    raytrace scenes                            list built-in scenes and examples
    raytrace render --help                     every render option
    """


@main.command("scenes")
def scenes_cmd():
    """List the built-in scenes and the example scene files."""
    from raytrace.scene.assets import assets_dir
    from raytrace.scene.builtin import BUILTIN
    from raytrace.scene.examples import describe, example_names
    click.echo("Built-in scenes (raytrace NAME):")
    for name, (_, desc) in sorted(BUILTIN.items()):
        click.echo(f"  {name:<13} {desc}")
    click.echo("Example scene files (raytrace NAME):")
    for name, path in example_names().items():
        click.echo(f"  {name:<13} {describe(path)}")
    click.echo(f"(the files are in {assets_dir()}; copy one to start a scene of your own)")


def _is_tty(stream):
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class _Progress:
    """A progress bar on stderr, shown only on a terminal and only once the
    render has run for a second (short renders stay quiet)."""
    DELAY_S = 1.0

    def __init__(self, enabled, label="rendering"):
        self.enabled = enabled and _is_tty(sys.stderr)
        self.label = label
        self.start = time.perf_counter()
        self.bar = None
        self.done = 0

    def __call__(self, rows_done, rows_total):
        raise_if_interrupted()          # each band or frame: a dropped Ctrl-C stops here
        if not self.enabled:
            return
        if self.bar is None and time.perf_counter() - self.start >= self.DELAY_S:
            self.bar = click.progressbar(length=rows_total, label=self.label, file=sys.stderr)
            self.bar.__enter__()
        if self.bar is not None:
            self.bar.update(rows_done - self.done)
        self.done = rows_done

    def close(self):
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def _compile_seconds():
    """Kernel compile seconds so far (kernels/compile_clock.py), 0 before
    any kernel package is imported: reading it imports nothing."""
    clock = sys.modules.get("raytrace.kernels.compile_clock")
    return clock.seconds() if clock is not None else 0.0


def _load_threads(options):
    """--threads bounds loading's threads too (a big teapot's tessellation
    runs on Numba's, scene/teapot.py), not only the render's."""
    threads = options.get("threads")
    if threads is not None:
        BY_NAME["threads"].check(threads)      # a bad count is a bad option, as at render
        import numba
        numba.set_num_threads(threads)


@contextlib.contextmanager
def _one_line_errors():
    """A bad option exits 2, any other raytrace error 1, each as one line
    (click prints it); Ctrl-C passes through to the caller."""
    try:
        yield
    except OptionError as exc:       # a render option's check names its flag (options.py)
        flag = getattr(exc, "flag", None)
        raise click.UsageError(f"{flag}: {exc}" if flag else str(exc)) from None
    except RaytraceError as exc:
        raise click.ClickException(str(exc)) from None
    except MemoryError:
        raise click.ClickException("out of memory: try a smaller image or fewer samples") from None


def _warnings_once():
    """Each warning, ours or a library's, as one line on stderr, once."""
    from raytrace.cli.messages import warnings_once
    return warnings_once()


def _runner(workers, scheduler):
    """Where the tasks run: a Dask cluster, or None (here)."""
    if workers is None and scheduler is None:
        return contextlib.nullcontext(None)
    from raytrace.cli.warmup import worker_payload
    from raytrace.frames.distributed import connect
    return connect(workers=workers, scheduler=scheduler, warm_up=worker_payload)


def _local_runner(stack, work):
    """A local cluster's runner (--workers), entered on ``stack`` (an
    ExitStack) before the scene loads: its processes start meanwhile, in
    the background (frames/distributed.py's connect).  None otherwise: a
    scheduler's is entered once the scene has loaded."""
    return None if work.workers is None else stack.enter_context(_runner(work.workers, None))


def _scene_kind(scene, scene_args):
    """The scene's kind (load.scene_kind); UsageError for a scene option
    (params.SceneArgs) that does not apply to it."""
    detail, view, up, crease, flat = (scene_args.detail, scene_args.view, scene_args.up,
                                      scene_args.crease, scene_args.flat)
    from raytrace.scene.load import scene_kind, unknown_scene_message
    kind = scene_kind(scene)
    if kind is None:
        raise click.UsageError(unknown_scene_message(scene))
    if detail is not None and not (kind == "builtin" and scene == "teapot"):
        raise click.UsageError("--detail applies to the teapot scene only")
    for name, value in (("--view", view), ("--up", up), ("--crease", crease), ("--flat", flat)):
        if value is not None and kind != "mesh":
            raise click.UsageError(f"{name} applies to mesh files only")
    if crease is not None and flat:
        raise click.UsageError("--crease and --flat contradict each other")
    return kind


def _announce_first_run(scene, kind, options):
    """A first run's notice, before Numba loads (so at once), with a path
    tracer's estimate for --integrator path or a scene file's integrator
    (its TOML read here: milliseconds).  None for a mesh file whose first
    bytes are not its format's, or a scene file that is not TOML: their
    error comes alone, not after a promise of seconds of compiling."""
    from pathlib import Path

    from raytrace.renderer import firstrun
    if not firstrun.first_run():
        return
    integrator = options.get("integrator")
    if kind == "mesh":
        from raytrace.scene.formats.mesh import looks_like_mesh
        if not looks_like_mesh(scene):
            return
    elif kind == "toml":
        from raytrace.scene.formats.scenefile import written_integrator
        try:
            written = written_integrator(scene)
        except RaytraceError:
            return
        if written not in (None, *BY_NAME["integrator"].choice_list()):
            return
        integrator = integrator or written
    accel, shadows = options.get("accel") or "bvh", options.get("shadows") or "hard"
    firstrun.announce_if_cold(firstrun.render_what(Path(scene).name, accel, shadows, integrator),
                              firstrun.command_estimate(accel, integrator,
                                                        Path(scene).stat().st_size if kind == "mesh" else 0))


@main.command("render")
@click.argument("scene")
@click.option("--bvol/--no-bvol", default=None,
              help="Per-object bounding boxes on/off: shorthand for --accel bvol / --accel none.")
@_render_options
@_scene_options
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="Image to write [default: SCENE.png]; frames: .gif, .mp4 or a pattern like "
                   "frames/spin_%04d.png.")
@click.option("--aov", type=AovType(), default=None,
              help="Also save these buffers (depth,normal,primid,cost) to OUTPUT's name with .aov.npz.")
@click.option("--heatmap", type=click.Path(dir_okay=False), default=None,
              help="Also write a false-colour PNG of per-pixel cost (box + primitive tests).")
@click.option("--show-structure", "show_depth", type=click.IntRange(min=0, max=64), default=None,
              metavar="DEPTH", help="Draw the structure's boxes (BVH nodes, kd-tree cells, grid "
                                    "cells, object boxes) down to DEPTH over the image.")
@_work_options
@click.option("--json", "as_json", is_flag=True, help="Print the statistics as JSON on stdout.")
@click.option("-q", "--quiet", is_flag=True, help="No table, no progress bar.")
def render_cmd(scene, bvol, scene_args, output, aov, heatmap, show_depth, work, as_json, quiet,
               **options):
    """Render SCENE to PNG (or frames: --turntable, -o .gif) and print the statistics table.

    SCENE is a built-in scene name (see `raytrace scenes`), a TOML scene
    file, or a mesh file (.obj, .ply, .stl, .off, .glb, .gltf), which is shown
    from an automatic camera on a ground plane.
    """
    from pathlib import Path

    from raytrace.renderer.firstrun import set_quiet
    from raytrace.scene.examples import resolve
    set_quiet(quiet)
    scene = resolve(scene)
    if bvol is not None:
        implied = "bvol" if bvol else "none"
        if options["accel"] is not None and options["accel"] != implied:
            raise click.UsageError(f"--{'bvol' if bvol else 'no-bvol'} contradicts "
                                   f"--accel {options['accel']}")
        options["accel"] = implied
    # Options not given keep RenderOptions' defaults; the image size goes to
    # the scene, whose camera a mesh file's framing fits to it.
    width, height = options.pop("width"), options.pop("height")
    options = {k: v for k, v in options.items() if v is not None}
    kind = _scene_kind(scene, scene_args)
    if kind == "builtin" or _is_file(scene):      # no notice before "no such file"
        _announce_first_run(scene, kind, options)
    animated = work.turntable is not None or _is_frame_path(output)
    still_extras = [flag for flag, value in (("--aov", aov), ("--heatmap", heatmap),
                                             ("--show-structure", show_depth)) if value is not None]
    _check_work(animated, still_extras, work)
    if animated:
        return _render_animation(scene, kind, output, work, as_json, quiet, options, width, height,
                                 scene_kwargs(scene_args))
    _check_image_path("-o/--output", output, linear=True)
    _check_image_path("--heatmap", heatmap)
    from raytrace.renderer.linear import is_linear
    if is_linear(output):
        _check_linear(output, show_depth, work)
    named = output is not None
    output = output or f"{scene if kind == 'builtin' else Path(scene).stem}.png"
    aov_out = _aov_out(output, aov)
    outputs = [Path(p).resolve() for p in (output, *_aov_files(aov_out), heatmap) if p is not None]
    if len(set(outputs)) != len(outputs):
        raise click.UsageError("--heatmap must differ from the output image and its .aov.npz")
    outputs = None
    try:
        with _one_line_errors(), contextlib.ExitStack() as stack:
            runner = _local_runner(stack, work)    # starting while the scene loads
            from raytrace.renderer.driver import RenderOptions, render
            from raytrace.renderer.output import check_writable
            from raytrace.scene.load import load_kernels, load_scene

            if show_depth is not None:
                from raytrace.accel.registry import DEFAULT, get
                get(options.get("accel", DEFAULT)).check_outline()
            _load_threads(options)
            from raytrace.renderer.firstrun import command_estimate, expecting
            accel, shadows = options.get("accel", "bvh"), options.get("shadows", "hard")
            t_load = time.perf_counter()
            with expecting(f"{scene}: {accel}, {shadows} shadows",
                           command_estimate(accel, options.get("integrator")), load=False):
                t_kernels = load_kernels(scene, scene_args.detail)   # compile time, not loading's
            compiled = _compile_seconds()
            with _warnings_once():
                sc = load_scene(scene, width=width, height=height, **scene_kwargs(scene_args))
            # A mesh file's kernels compile as they are first used: compile time too.
            t_kernels += _compile_seconds() - compiled
            # The imports load_kernels needed (Numba's) are loading's.
            t_load = time.perf_counter() - t_load - t_kernels
            raise_if_interrupted()
            if not named and kind == "toml":      # a scene file's name names its image
                output = f"{sc.name}.png"
                aov_out = _aov_out(output, aov)
            for path in (output, *_aov_files(aov_out), heatmap):
                if path is not None:
                    check_writable(path)
            progress = _Progress(enabled=not quiet)
            opts = RenderOptions(aov=bool(aov or heatmap), progress=progress, **options)
            try:
                if work.tiles is None and work.workers is None and work.scheduler is None:
                    result = render(sc, opts, drop_meshes=True)
                else:
                    from raytrace.frames.batch import render_tiled
                    if runner is None:
                        runner = stack.enter_context(_runner(None, work.scheduler))
                    n = work.tiles or (4 * runner.workers if runner is not None else 1)
                    result = render_tiled(sc, opts, runner, n)
            finally:
                progress.close()
            result.stats["time"]["load_s"] = t_load
            result.stats["time"]["compile_s"] += t_kernels
            if show_depth is not None:
                result.image = _show_structure(result, sc, opts.accel, show_depth)
            raise_if_interrupted()
            from raytrace.renderer.output import Outputs
            with Outputs() as outputs:
                notes = _write_outputs(result, output, aov, aov_out, heatmap, outputs)
    except KeyboardInterrupt:
        done = "outputs written" if outputs is not None and outputs.committed else "no image written"
        click.echo(f"{interrupt.label()}: {done}", err=True)
        sys.exit(interrupt.exit_code())
    from raytrace.renderer.stats import (  # here: it loads Numba, which a bad file never needs
        format_table,
        to_json,
    )
    if as_json:
        click.echo(to_json(result.stats))
    elif not quiet:
        click.echo(format_table(result.stats))
        click.echo(f"wrote {output}")
        for note in notes:
            click.echo(note)
        cut = result.stats["counters"]["depth_limited_rays"]
        if cut:
            click.echo(f"{cut:,} mirror and glass rays were cut by --max-depth "
                       f"{result.stats['max_depth']}: raise it where glass looks dark")


def _render_animation(scene, kind, output, work, as_json, quiet, options, width, height,
                      scene_opts):
    """`raytrace SCENE --turntable N` or -o with frames: a turntable or the
    scene file's [animation], written frame by frame (frames/writers.py);
    work: params.WorkArgs."""
    resume = work.resume
    from pathlib import Path

    from raytrace.errors import RaytraceError
    from raytrace.frames.writers import check_frame_output
    stem = scene if kind == "builtin" else Path(scene).stem
    if output is not None:
        try:
            check_frame_output(output, resume=resume)
        except RaytraceError as exc:
            raise click.UsageError(f"-o/--output: {exc}") from None
    try:
        with _one_line_errors(), contextlib.ExitStack() as stack:
            runner = _local_runner(stack, work)    # starting while the scene loads
            from raytrace.frames.batch import animate
            from raytrace.renderer.driver import RenderOptions
            from raytrace.scene.animation import camera_path
            from raytrace.scene.load import load_scene

            with _warnings_once():
                sc = load_scene(scene, width=width, height=height, **scene_opts)
            raise_if_interrupted()
            if output is None:
                output = f"{sc.name if kind == 'toml' else stem}.gif"
                check_frame_output(output, resume=resume)
            cameras = camera_path(sc, work.turntable)
            progress = _Progress(enabled=not quiet, label="frames")
            opts = RenderOptions(**options)
            try:
                if runner is None:
                    runner = stack.enter_context(_runner(None, work.scheduler))
                _, stats = animate(sc, cameras, opts, output=output, fps=work.fps or 24,
                                   resume=resume, runner=runner, tiles=work.tiles or 1,
                                   progress=progress)
            finally:
                progress.close()
            stats["output"] = str(output)
    except (KeyboardInterrupt, Exception) as exc:
        # A signal that lands in a library's C code (the video encoder's)
        # may come back as that library's error: still an interruption, of
        # an animation (cli/command.py would say "no image written").
        if not isinstance(exc, KeyboardInterrupt) and not interrupt.interrupted():
            raise
        click.echo(f"{interrupt.label()}: no animation written" if not _is_numbered(output)
                   else f"{interrupt.label()}: the frames written are complete", err=True)
        sys.exit(interrupt.exit_code())
    from raytrace.renderer.stats import format_table, to_json
    if as_json:
        click.echo(to_json(stats))
    elif not quiet:
        click.echo(format_table(stats))
        skipped = stats.get("frames_skipped", 0)
        click.echo(f"wrote {stats['frames'] - skipped} frames to {output}"
                   + (f" ({skipped} already there)" if skipped else ""))


QUICK_SIZE = (320, 240)


@main.command("compare")
@click.argument("scene")
@click.option("--accel", "accel_list", default=None, metavar="LIST",
              help="Structures to compare, comma-separated; bvh:median and bvh:lbvh are the BVH "
                   "with another builder [default: every structure].")
@lambda command: _render_options(command, skip=("accel",))
@_scene_options
@click.option("--repeat", type=click.IntRange(min=1, max=100), default=None, metavar="N",
              help="Render each structure N times, in turn, and keep the fastest [default: 3].")
@click.option("--quick", is_flag=True,
              help=f"{QUICK_SIZE[0]}x{QUICK_SIZE[1]} and one render each (unless --width, "
                   "--height or --repeat say otherwise).")
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="The comparison figure [default: SCENE.compare.png].")
@click.option("--json", "as_json", is_flag=True, help="Print the comparison as JSON on stdout.")
@click.option("-q", "--quiet", is_flag=True, help="No table.")
@click.pass_context
def compare_cmd(ctx, scene, accel_list, scene_args, repeat, quick, output, as_json, quiet,
                **options):
    """Render SCENE with every structure and compare them.

    Prints the workshop's table (build and render time, speedup, rays,
    tests and nodes or cells per ray, memory), checks that every structure
    made the same image (exit 1 if not), and writes a figure: the image,
    each structure's cost heatmap on one colour scale, and render times.
    """
    from pathlib import Path

    from raytrace.renderer.firstrun import set_quiet
    from raytrace.scene.examples import resolve
    set_quiet(quiet)
    scene = resolve(scene)
    kind = _scene_kind(scene, scene_args)
    _check_image_path("-o/--output", output)
    width, height = options.pop("width"), options.pop("height")
    if quick and width is None and height is None:
        width, height = QUICK_SIZE
    repeat = repeat or (1 if quick else 3)
    options = {k: v for k, v in options.items() if v is not None}
    try:
        with _one_line_errors():
            from raytrace.cli.compare import compare, default_entries, format_table, parse_entries, to_dict
            from raytrace.cli.figure import figure
            from raytrace.renderer.driver import RenderOptions
            from raytrace.renderer.output import Outputs, check_writable, image_writer
            from raytrace.renderer.stats import to_json
            from raytrace.scene.load import load_scene

            entries = parse_entries(accel_list) if accel_list is not None else default_entries()
            _load_threads(options)
            with _warnings_once():
                sc = load_scene(scene, width=width, height=height, **scene_kwargs(scene_args))
            raise_if_interrupted()
            stem = sc.name if kind == "toml" else scene if kind == "builtin" else Path(scene).stem
            output = output or f"{stem}.compare.png"
            check_writable(output)
            show = not (quiet or as_json) and _is_tty(sys.stderr)
            result = compare(sc, entries, RenderOptions(**options), repeat=repeat,
                             progress=(lambda label: click.echo(f"rendering: {label}", err=True))
                             if show else None)
            s = result.entries[0].stats
            setting = (f"{s['width']}x{s['height']}, {s['spp']} spp, {s['shadows']} shadows, "
                       f"{s['triangles']:,} triangles, {s['threads']} threads, best of {repeat}")
            raise_if_interrupted()
            with Outputs() as outputs:
                outputs.add(output, image_writer(figure(result, setting)[0], output))
    except KeyboardInterrupt:
        click.echo(f"{interrupt.label()}: no comparison written", err=True)
        sys.exit(interrupt.exit_code())
    if as_json:
        click.echo(to_json({**to_dict(result), "output": str(output)}))
    elif not quiet:
        click.echo(f"{sc.name}: {setting}")
        click.echo(format_table(result))
        click.echo(f"wrote {output}")
    if not result.identical:
        click.echo(f"Error: {result.differences[0][0]} made a different image", err=True)
        ctx.exit(1)


@main.command("warmup")
@click.option("--all", "everything", is_flag=True,
              help="Every structure and builder, both shadow kernels, textures, mirrors, ray "
                   "queries and loading: minutes, once.")
@click.option("--accel", "accel_list", default="bvh", metavar="LIST", show_default=True,
              help="Structures, comma-separated (bvh:median and bvh:lbvh: the BVH's other builders).")
@click.option("--shadows", "shadow_list", default="hard", metavar="LIST", show_default=True,
              help="Shadow modes: none and hard share a kernel, soft has its own.")
@click.option("--with", "feature_list", default="", metavar="LIST",
              help="Also: textures, mirrors (and glass), path (--integrator path), queries "
                   "(RayScene), loading (big teapots and meshes).")
@click.option("-q", "--quiet", is_flag=True, help="No progress lines.")
def warmup_cmd(everything, accel_list, shadow_list, feature_list, quiet):
    """Compile kernels into the cache now, so later commands and API calls
    start warm: for container images, CI, and each machine (or Dask worker)
    that shares NUMBA_CACHE_DIR, all of one CPU type.
    """
    from raytrace.cli.compare import parse_entries
    from raytrace.cli.warmup import FEATURES, plan, run
    if everything:
        from raytrace.options import BY_NAME
        accels = [*BY_NAME["accel"].choice_list(), "bvh:median", "bvh:lbvh"]
        shadows, features = ["hard", "soft"], list(FEATURES)
    else:
        with _one_line_errors():
            accels = [e.label for e in parse_entries(accel_list)]
        shadows = [s.strip() for s in shadow_list.split(",") if s.strip()]
        for s in shadows:
            if s not in ("none", "hard", "soft"):
                raise click.UsageError(f"--shadows: unknown mode {s!r} (none, hard, soft)")
        features = [f.strip() for f in feature_list.split(",") if f.strip()]
        for f in features:
            if f not in FEATURES:
                raise click.UsageError(f"--with: unknown feature {f!r} ({', '.join(FEATURES)})")
    steps = plan(accels, shadows or ["hard"], features)

    def started(k, n, label):
        if not quiet:
            click.echo(f"[{k}/{n}] {label} ...", err=True, nl=False)

    def done(k, n, label, seconds):
        if not quiet:
            click.echo(f" {seconds:.1f} s", err=True)
    t0 = time.perf_counter()
    try:
        with _one_line_errors():
            run(steps, started, done)
    except KeyboardInterrupt:
        click.echo("\ninterrupted: the kernels compiled so far stay in the cache", err=True)
        sys.exit(130)
    if not quiet:
        from raytrace.kernels.jitconfig import numba
        click.echo(f"warm: {len(steps)} steps in {time.perf_counter() - t0:.1f} s; cache "
                   f"{numba.config.CACHE_DIR}", err=True)


def entry():
    """The `raytrace` command: click's group, with Ctrl-C reported as an
    interruption (exit 130; SIGTERM 143, SIGHUP 129) wherever it lands, and a bad argument as one
    line (exit 2), without click's usage lines."""
    from raytrace.cli.messages import escape
    try:
        with _warnings_once():
            rv = main(standalone_mode=False)
    except (KeyboardInterrupt, click.exceptions.Abort):
        click.echo(f"{interrupt.label()}: no image written", err=True)
        sys.exit(interrupt.exit_code())
    except click.exceptions.NoArgsIsHelpError as exc:   # a bare `raytrace`: the help
        click.echo(exc.ctx.get_help())
        sys.exit(0)
    except click.exceptions.UsageError as exc:
        click.echo(f"Error: {escape(exc.format_message())}", err=True)
        sys.exit(2)
    except click.ClickException as exc:
        click.echo(f"Error: {escape(exc.format_message())}", err=True)
        sys.exit(exc.exit_code)
    sys.exit(rv if isinstance(rv, int) else 0)


if __name__ == "__main__":
    entry()
