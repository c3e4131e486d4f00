"""Every render option, defined once: its name, type, default, range and
help.  The command line's options (cli/main.py), the render's validation
(renderer/driver.py), the scene files' limits (scene/formats/scenefile.py) and the README's
options table (checked by tests/test_readme.py) are derived from here.

Imports nothing heavy: the command line reads it to build --help.
"""
import math
from dataclasses import dataclass

from raytrace.errors import OptionError
from raytrace.kernels.limits import MAX_BOUNCES


def _structures():
    from raytrace.accel.registry import STRUCTURES
    return tuple(STRUCTURES)


def _bvh_builders():
    return ("sah", "median", "lbvh")       # raytrace/accel/bvh/build.py BUILDERS


def _max_threads():
    import numba
    return numba.config.NUMBA_NUM_THREADS


@dataclass(frozen=True)
class Option:
    name: str                 # keyword of raytrace.render (RenderOptions field)
    kind: str                 # "choice", "int" or "float"
    default: object           # None: decided at render time (default_text says how)
    help: str                 # one line: --help and the README say this
    choices: object = None    # a tuple, or a function giving it (a registry's names)
    lo: float = None          # inclusive range, for numbers
    hi: object = None         # a number, or a function giving it
    noun: str = None          # how an error names it ("shadow mode"); default: name
    default_text: str = None  # the default as --help and the README show it
    metavar: str = None

    @property
    def flag(self):
        return "--" + self.name.replace("_", "-")

    @property
    def label(self):
        return self.noun or self.name.replace("_", " ")

    def choice_list(self):
        return tuple(self.choices() if callable(self.choices) else self.choices)

    def high(self):
        return self.hi() if callable(self.hi) else self.hi

    def shown_default(self):
        if self.default_text is not None:
            return self.default_text
        return f"`{self.default}`" if self.kind == "choice" else f"{self.default:g}"

    def check(self, value):
        """Raise RaytraceError unless value is valid (None: the default).
        The OptionError's ``flag`` names the option for the command line."""
        try:
            self._check(value)
        except OptionError as exc:
            exc.flag = self.flag
            raise

    def _check(self, value):
        if value is None and self.default is None:
            return
        if self.kind == "choice":
            if not isinstance(value, str) or value not in self.choice_list():
                raise OptionError(f"unknown {self.label} {value!r} "
                                    f"(choose from {', '.join(self.choice_list())})")
            return
        integral = self.kind == "int"
        number = (int,) if integral else (int, float)
        import numpy as np
        number += (np.integer,) if integral else (np.integer, np.floating)
        if isinstance(value, bool) or not isinstance(value, number):
            raise OptionError(f"{self.label} must be {'an integer' if integral else 'a number'}, "
                                f"got {value!r}")
        lo, hi = self.lo, self.high()
        if not (math.isfinite(value) and lo <= value <= hi):
            raise OptionError(f"{self.label} must be between {lo:g} and {hi:g}, got {value!r}"
                                if not integral else
                                f"{self.label} must be between {lo} and {hi}, got {value}")


OPTIONS = (
    Option("accel", "choice", "bvh", "acceleration structure; every one gives the same image",
           choices=_structures, noun="acceleration structure"),
    Option("bvh_build", "choice", "sah", "BVH builder: binned SAH, object median, or LBVH",
           choices=_bvh_builders, noun="BVH builder"),
    Option("leaf_size", "int", 4, "BVH leaves hold at most this many primitives", lo=1, hi=64,
           metavar="N"),
    Option("grid_density", "float", 3.0, "grid cells along the longest axis per cube root of N",
           lo=0.01, hi=64.0, metavar="D"),
    Option("shadows", "choice", "hard", "shadow rays: none, one per light, or the light's area "
           "sampled", choices=("none", "hard", "soft"), noun="shadow mode"),
    Option("light_samples", "int", 81, "shadow rays per point with soft shadows",
           lo=1, hi=65536, metavar="N"),
    Option("pattern", "choice", "stratified", "light sample placement (grid and stratified need a "
           "square number)", choices=("grid", "random", "stratified", "halton"),
           noun="sampling pattern"),
    Option("max_depth", "int", None, "bounces: mirror and glass, or a path's", lo=0,
           hi=MAX_BOUNCES, default_text="5; path: 16", metavar="N"),
    Option("integrator", "choice", None, "`path`: indirect light and emission",
           choices=("whitted", "path"), default_text="`whitted`, or the scene's"),
    Option("sampler", "choice", "independent", "path tracer: hashed or Owen-scrambled Sobol "
           "numbers", choices=("independent", "sobol")),
    Option("texture_filter", "choice", "box", "checker averaged over each pixel's footprint and "
           "image textures bilinear, or `none`: point-sampled, nearest texel",
           choices=("box", "none"), noun="texture filter"),
    Option("width", "int", None, "image width in pixels", lo=1, hi=1 << 20,
           default_text="640, or the scene's", metavar="W"),
    Option("height", "int", None, "image height in pixels", lo=1, hi=1 << 20,
           default_text="480, or the scene's", metavar="H"),
    Option("spp", "int", 1, "camera rays per pixel (anti-aliasing)", lo=1, hi=4096, metavar="N"),
    Option("seed", "int", 0, "random seed: the same seed, the same image", lo=0, hi=2 ** 63 - 1,
           metavar="S"),
    Option("threads", "int", None, "load and render threads", lo=1, hi=_max_threads,
           default_text="all cores", metavar="N"),
)
BY_NAME = {o.name: o for o in OPTIONS}


def readme_row(opt):
    """The option's row of the README's options table."""
    values = "\\|".join(opt.choice_list()) if opt.kind == "choice" else opt.metavar
    return f"| `{opt.flag} {values}` | {opt.shown_default()} | {opt.help} |"

# Scene options the command line also takes (not render options): the
# teapot's tessellation and the camera's field of view; scene files are
# held to the same limits.
DETAIL = Option("detail", "int", 4, "teapot tessellation: N x N quads per Bezier patch (4: 992 "
                "triangles; 43: 117,992)", lo=1, hi=256, metavar="N")
FOV_RANGE = (0.0, 180.0)   # degrees, both ends excluded
# Mesh files' smooth shading: normals are split where faces meet at more
# than this (scene files' meshes take it as `crease`).
CREASE = Option("crease", "float", 35.0, "mesh files: smooth normals across edges up to this "
                "angle, split at sharper ones", lo=0.0, hi=180.0, noun="crease angle",
                metavar="DEG")
