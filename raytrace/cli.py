"""Command line: ``raytrace SCENE [options]`` renders, ``raytrace scenes`` lists.

Bad arguments exit 2 (click's UsageError), bad input or runtime failures
exit 1 (ClickException); neither prints a traceback.
"""
import sys
import time

import click

from .errors import RaytraceError

ACCEL_CHOICES = ("none", "bvol", "bvh", "grid")
DEFAULT_ACCEL = "bvol"


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
    raytrace scenes                            list the built-in scenes
    raytrace render --help                     every render option
    """


@main.command("scenes")
def scenes_cmd():
    """List the built-in scenes."""
    from .scenes.builtin import BUILTIN
    for name, (_, desc) in sorted(BUILTIN.items()):
        click.echo(f"{name:<10} {desc}")


def _load_scene(name, detail):
    from .scenes.builtin import BUILTIN
    if name not in BUILTIN:
        raise click.UsageError(f"unknown scene {name!r} (built-in scenes: {', '.join(sorted(BUILTIN))})")
    factory = BUILTIN[name][0]
    if detail is not None:
        if name != "teapot":
            raise click.UsageError("--detail applies to the teapot scene only")
        return factory(detail=detail)
    return factory()


class _Progress:
    """A progress bar on stderr, shown only on a terminal and only once the
    render has run for a second (short renders stay quiet)."""

    def __init__(self, enabled):
        self.enabled = enabled and sys.stderr.isatty()
        self.start = time.perf_counter()
        self.bar = None
        self.done = 0

    def __call__(self, rows_done, rows_total):
        if not self.enabled:
            return
        if self.bar is None and time.perf_counter() - self.start > 1.0:
            self.bar = click.progressbar(length=rows_total, label="rendering", file=sys.stderr)
            self.bar.__enter__()
        if self.bar is not None:
            self.bar.update(rows_done - self.done)
        self.done = rows_done

    def close(self):
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


@main.command("render")
@click.argument("scene")
@click.option("--accel", type=click.Choice(ACCEL_CHOICES), default=None,
              help=f"Acceleration structure [default: {DEFAULT_ACCEL}].")
@click.option("--bvol/--no-bvol", default=None,
              help="Per-object bounding boxes on/off: shorthand for --accel bvol / --accel none.")
@click.option("--shadows", type=click.Choice(["none", "hard", "soft"]), default="hard", show_default=True,
              help="none: no shadow rays; hard: one per light; soft: an area light sampled.")
@click.option("--light-samples", type=click.IntRange(min=1), default=81, show_default=True,
              help="Shadow rays per shading point for soft shadows (9x9 by default).")
@click.option("--pattern", type=click.Choice(["grid", "random", "stratified", "halton"]),
              default="stratified", show_default=True, help="Area-light sampling pattern.")
@click.option("--detail", type=click.IntRange(min=1, max=256), default=None,
              help="Teapot tessellation: N x N quads per patch [default: 4, ~1k triangles].")
@click.option("--width", type=click.IntRange(min=1), default=None, help="Image width [default: 640].")
@click.option("--height", type=click.IntRange(min=1), default=None, help="Image height [default: 480].")
@click.option("--spp", type=click.IntRange(min=1, max=4096), default=1, show_default=True,
              help="Camera samples per pixel (jittered anti-aliasing).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed for every random sample (same seed, same image).")
@click.option("--threads", type=click.IntRange(min=1), default=None,
              help="Render threads [default: all cores].")
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="PNG to write [default: SCENE.png].")
@click.option("--json", "as_json", is_flag=True, help="Print the statistics as JSON on stdout.")
@click.option("-q", "--quiet", is_flag=True, help="No table, no progress bar.")
def render_cmd(scene, accel, bvol, shadows, light_samples, pattern, detail, width, height, spp,
               seed, threads, output, as_json, quiet):
    """Render SCENE (a built-in scene name; see `raytrace scenes`) to PNG and
    print the statistics table."""
    if bvol is not None:
        implied = "bvol" if bvol else "none"
        if accel is not None and accel != implied:
            raise click.UsageError(f"--{'bvol' if bvol else 'no-bvol'} contradicts --accel {accel}")
        accel = implied
    accel = accel or DEFAULT_ACCEL
    output = output or f"{scene}.png"
    try:
        from .output import check_writable, write_png
        from .driver import RenderOptions, render
        from .stats import format_table, to_json

        check_writable(output)
        sc = _load_scene(scene, detail)
        progress = _Progress(enabled=not quiet)
        opts = RenderOptions(accel=accel, shadows=shadows, light_samples=light_samples,
                             pattern=pattern, width=width, height=height, spp=spp, seed=seed,
                             threads=threads, progress=progress)
        try:
            result = render(sc, opts)
        finally:
            progress.close()
        write_png(output, result.image)
    except RaytraceError as exc:
        raise click.ClickException(str(exc)) from None
    except MemoryError:
        raise click.ClickException("out of memory: try a smaller image or fewer samples") from None
    except KeyboardInterrupt:
        click.echo("interrupted: no image written", err=True)
        sys.exit(130)
    result.stats["output"] = str(output)
    if as_json:
        click.echo(to_json(result.stats))
    elif not quiet:
        click.echo(format_table(result.stats))
        click.echo(f"wrote {output}")


if __name__ == "__main__":
    main()
