"""The command line's option types and the decorators that add the shared
options (render, scene, work) to a command, each derived from
raytrace/options.py."""
import functools
from collections import namedtuple

import click

from raytrace.options import CREASE, DETAIL, FOV_RANGE, OPTIONS


class ViewType(click.ParamType):
    """--view: a named view, or AZIMUTH,ELEVATION in degrees."""
    name = "view"

    def convert(self, value, param, ctx):
        from raytrace.scene.views import VIEWS
        if isinstance(value, tuple) or value in VIEWS:
            return value
        parts = str(value).split(",")
        try:
            if len(parts) != 2:
                raise ValueError
            az, el = (float(x) for x in parts)
        except ValueError:
            self.fail(f"{value!r} is neither a view ({', '.join(VIEWS)}) nor AZIMUTH,ELEVATION "
                      "in degrees", param, ctx)
        import math
        if not math.isfinite(az):
            self.fail(f"azimuth must be a finite number of degrees, got {parts[0].strip()!r}",
                      param, ctx)
        if not -90.0 <= el <= 90.0:
            self.fail(f"elevation must be between -90 and 90 degrees, got {parts[1].strip()!r}",
                      param, ctx)
        return (az, el)


class AovType(click.ParamType):
    name = "list"

    def convert(self, value, param, ctx):
        from raytrace.renderer.aov import parse_aov_list
        if isinstance(value, list):
            return value
        try:
            return parse_aov_list(value)
        except ValueError as exc:
            self.fail(str(exc), param, ctx)


def _view_options(view, up):
    """--view and --up as load_scene's keyword arguments."""
    opts = {}
    if isinstance(view, tuple):
        opts = dict(azimuth=view[0], elevation=view[1])
    elif view is not None:
        opts = dict(view=view)
    if up is not None:
        opts["up"] = up
    return opts


def _up_choices():
    from raytrace.scene.views import UP_AXES
    return UP_AXES


class FiniteFloatRange(click.FloatRange):
    """click's FloatRange lets NaN through (every comparison with it is
    false); this one does not."""

    def convert(self, value, param, ctx):
        import math
        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return rv


def _click_type(opt):
    """The click type of a render option, from its definition (options.py).
    A range given by a function (threads: the machine's cores) is checked
    at render time, and still exits 2."""
    if opt.kind == "choice":
        return click.Choice(opt.choice_list())
    hi = None if callable(opt.hi) else opt.hi
    if opt.kind == "int":
        return click.IntRange(min=opt.lo, max=hi)
    return FiniteFloatRange(min=opt.lo, max=hi)


def _render_options(command, skip=()):
    """Add every render option of options.py (but those in ``skip``) to a
    click command."""
    for opt in reversed(OPTIONS):
        if opt.name in skip:
            continue
        shown = opt.default_text or opt.default
        command = click.option(opt.flag, opt.name, type=_click_type(opt), default=None,
                               metavar=opt.metavar,
                               help=f"{opt.help.replace('`', '')} [default: {shown}]")(command)
    return command


# A command's scene options and work options reach it as one record each
# (``scene_args``, ``work``), not as a dozen keyword arguments.
SceneArgs = namedtuple("SceneArgs", ["detail", "view", "up", "crease", "flat", "fov"])
WorkArgs = namedtuple("WorkArgs", ["turntable", "fps", "resume", "tiles", "workers", "scheduler"])


def _as_record(command, record, name):
    """``command`` called with its options named in ``record`` gathered into
    one keyword argument ``name``."""
    @functools.wraps(command)
    def gathered(*args, **kwargs):
        kwargs[name] = record(*(kwargs.pop(field) for field in record._fields))
        return command(*args, **kwargs)
    return gathered


def scene_kwargs(scene_args):
    """load.load_scene's keyword arguments for the scene options."""
    s = scene_args
    return dict(detail=s.detail, fov=s.fov, crease=s.crease, flat=s.flat,
                **_view_options(s.view, s.up))


def _scene_options(command):
    """How the scene is made: the teapot's detail, a mesh file's framing,
    the field of view; the command gets them as ``scene_args``."""
    command = _as_record(command, SceneArgs, "scene_args")
    options = [
        click.option("--detail", type=click.IntRange(min=DETAIL.lo, max=DETAIL.hi), default=None,
                     metavar=DETAIL.metavar, help=f"{DETAIL.help} [default: {DETAIL.default}]."),
        click.option("--view", type=ViewType(), default=None,
                     help="Mesh files: front, back, left, right, top, bottom, iso, or "
                          "AZIMUTH,ELEVATION in degrees [default: iso]."),
        click.option("--up", type=click.Choice(_up_choices()), default=None,
                     help="Mesh files: the model's up axis [default: y]."),
        click.option("--crease", type=FiniteFloatRange(min=CREASE.lo, max=CREASE.hi), default=None,
                     metavar=CREASE.metavar,
                     help=f"{CREASE.help[0].upper()}{CREASE.help[1:]} (degrees; when the file has "
                          f"no normals) [default: {CREASE.default:g}]."),
        click.option("--flat", is_flag=True, default=None,
                     help="Mesh files: flat shading, one normal per triangle."),
        click.option("--fov", type=FiniteFloatRange(min=FOV_RANGE[0], max=FOV_RANGE[1],
                                                    min_open=True, max_open=True), default=None,
                     help="Vertical field of view in degrees [default: the scene's, 60 for "
                          "meshes]."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def _work_options(command):
    """Frame sequences, tiles, and where the work runs (frames/batch.py,
    frames/distributed.py); the command gets them as ``work``."""
    command = _as_record(command, WorkArgs, "work")
    options = [
        click.option("--turntable", type=click.IntRange(min=1, max=100_000), default=None,
                     metavar="N", help="Render N frames orbiting the camera about its look-at "
                                       "point (around the scene's up axis) [-o default: SCENE.gif]."),
        click.option("--fps", type=FiniteFloatRange(min=1, max=240), default=None,
                     help="Frames per second of a .gif or .mp4 [default: 24]."),
        click.option("--resume", is_flag=True, default=False,
                     help="PNG sequences: keep the frames already written, render the rest."),
        click.option("--tiles", type=click.IntRange(min=1, max=1 << 16), default=None,
                     metavar="N", help="Render each image as N bands of rows, one task each "
                                       "[default: 1; 4 per Dask worker for a still]."),
        click.option("--workers", type=click.IntRange(min=1, max=1024), default=None,
                     metavar="N", help="Run the tasks on a local Dask cluster of N processes "
                                       "(the distributed extra)."),
        click.option("--scheduler", default=None, envvar="DASK_SCHEDULER_ADDRESS",
                     metavar="ADDRESS", help="Run the tasks on the Dask cluster at ADDRESS "
                                             "[default: $DASK_SCHEDULER_ADDRESS]."),
    ]
    for option in reversed(options):
        command = option(command)
    return command
