"""Render driver: options -> buffers -> structure -> kernel bands -> result.

Python owns validation and dtype casting; the kernels see only arrays.
"""
import functools
import math
import sys
import time
from dataclasses import dataclass, field, make_dataclass
from numbers import Real
from typing import NamedTuple

import numpy as np

from raytrace.errors import OptionError, RaytraceError
from raytrace.kernels.buffers import Lights, f64, i64, n_bounded
from raytrace.options import BY_NAME, OPTIONS
from raytrace.scene.formats.mesh import available_memory

# Bytes a pixel costs while rendering: float32 RGB + uint8 RGB, and with AOVs
# depth f32, normal 3xf32, prim id i64, cost i64.
BYTES_PER_PIXEL = 12 + 3
BYTES_PER_PIXEL_AOV = 4 + 12 + 8 + 8
# Values converted to sRGB at a time (to_srgb8): a few MB of temporaries.
SRGB_BAND_VALUES = 1 << 18


# The render's options: every field of options.OPTIONS with its default,
# plus the AOV switch and a progress callback.
RenderOptions = make_dataclass(
    "RenderOptions",
    [(o.name, object, field(default=o.default)) for o in OPTIONS]
    + [("aov", bool, field(default=False)),
       ("progress", object, field(default=None))])    # callable(rows_done, rows_total)
RenderOptions.__doc__ = "Options of render(); see raytrace/options.py for each."


@dataclass
class RenderResult:
    image: np.ndarray            # (h, w, 3) uint8 sRGB
    linear: np.ndarray           # (h, w, 3) float32 linear radiance
    stats: dict
    aovs: dict = field(default_factory=dict)
    structure: object = None     # the acceleration structure's layout, as built

    def save(self, path):
        """Write the image to ``path``, its format by the extension: .png,
        .jpg, ... (8-bit sRGB) or .npy, .pfm, .exr (linear float32)."""
        from raytrace.renderer.display import save_result
        return save_result(self, path)

    def _repr_png_(self):            # Jupyter shows the image
        from raytrace.renderer.display import png_bytes
        return png_bytes(self.image)

    def __repr__(self):
        from raytrace.renderer.display import result_repr
        return result_repr(self)


def _check_int(name, value, lo, hi):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise RaytraceError(f"{name} must be an integer, got {value!r}")
    if not lo <= value <= hi:
        raise RaytraceError(f"{name} must be between {lo} and {hi}, got {value}")


def _check_materials(scene):
    """Raise RaytraceError naming the first object whose material has a
    colour or a weight that is not a finite number (NaN would render as
    garbage pixels, with a warning from NumPy's cast)."""
    for k, obj in enumerate(scene.objects):
        m = getattr(obj, "material", None)
        if m is None:
            continue
        emission = list(np.ravel(np.asarray(m.emission, dtype=object)))
        values = [*np.ravel(np.asarray(m.color, dtype=object)), m.ambient, m.diffuse, m.specular,
                  m.shininess, m.checker, m.reflect, m.transmit, m.ior, *emission, m.glossy]
        name = getattr(obj, 'name', type(obj).__name__)
        for x in values:
            if isinstance(x, (bool, np.bool_)) or not isinstance(x, Real) or not math.isfinite(x):
                raise RaytraceError(f"object {k} ({name}): its material has {x!r} among its "
                                    "colour, weights and emission; they must be finite numbers")
        if not 0.0 <= m.glossy <= 1.0:
            raise RaytraceError(f"object {k} ({name}): its material's glossy weight must be "
                                f"between 0 and 1, got {m.glossy!r}")
        if len(emission) != 3 or min(emission) < 0:
            raise RaytraceError(f"object {k} ({name}): its material's emission must be three "
                                f"numbers of at least 0 (r, g, b), got {m.emission!r}")


def validate(opts, scene):
    """Raise RaytraceError for any option the render cannot honour."""
    from raytrace.scene.model import Camera
    if not isinstance(scene.camera, Camera):
        raise RaytraceError(f"scene {scene.name!r} has no camera (got {scene.camera!r})")
    if opts.progress is not None and not callable(opts.progress):
        raise OptionError(f"progress must be a function (rows done, rows in all) or None, "
                          f"got {opts.progress!r}")
    for opt in OPTIONS:
        opt.check(getattr(opts, opt.name))
    BY_NAME["integrator"].check(integrator_of(opts, scene))
    check_path_options(opts, scene)
    w = scene.camera.width if opts.width is None else opts.width
    h = scene.camera.height if opts.height is None else opts.height
    BY_NAME["width"].check(w)
    BY_NAME["height"].check(h)
    if opts.pattern in ("grid", "stratified") and opts.shadows == "soft":
        side = math.isqrt(opts.light_samples)
        if side * side != opts.light_samples:
            raise OptionError(f"the {opts.pattern} pattern needs a square number of light samples "
                              f"(got {opts.light_samples}; try {side * side} or {(side + 1) ** 2})")
    if opts.shadows == "soft":
        for k, light in enumerate(scene.lights):
            if light.samples:  # a light's own count overrides light_samples
                where = f"{light.where}.samples" if light.where else f"light {k} samples"
                _check_int(where, light.samples, 1, BY_NAME["light_samples"].hi)
                side = math.isqrt(light.samples)
                if opts.pattern in ("grid", "stratified") and side * side != light.samples:
                    raise RaytraceError(f"{where}: the {opts.pattern} pattern needs a square "
                                        f"number of light samples, got {light.samples}")
    _check_materials(scene)
    if not isinstance(opts.aov, (bool, np.bool_)):
        raise RaytraceError(f"aov must be True or False, got {opts.aov!r}")
    # Each row also has an int64 counter row: little, but a 1-pixel-wide
    # image of a million rows needs 80 MB of them.
    from raytrace.kernels.counters import N_COUNTERS
    need = (w * h * (BYTES_PER_PIXEL + (BYTES_PER_PIXEL_AOV if opts.aov else 0))
            + h * 8 * N_COUNTERS)
    if need > available_memory():
        raise RaytraceError(f"a {w}x{h} image needs {need / 2**30:.1f} GiB of memory, "
                            f"more than the {available_memory() / 2**30:.1f} GiB available")
    return w, h


def camera_buffer(cam, width, height):
    """eye, forward, right and up, the last two scaled to the image plane."""
    eye = np.asarray(cam.eye, dtype=float)
    fwd = np.asarray(cam.look_at, dtype=float) - eye
    up = np.asarray(cam.up, dtype=float)
    if not np.all(np.isfinite(np.concatenate([eye, fwd, up]))):
        raise RaytraceError("camera position, look-at and up must be finite")
    if not np.linalg.norm(fwd) > 0:
        raise RaytraceError("camera look-at must differ from its position")
    if not 0 < cam.fov < 180:
        raise RaytraceError(f"camera field of view must be between 0 and 180 degrees, got {cam.fov}")
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, up)
    if not np.linalg.norm(right) > 1e-12:
        raise RaytraceError("camera up vector is parallel to the view direction")
    right /= np.linalg.norm(right)
    true_up = np.cross(right, fwd)
    half_h = math.tan(math.radians(cam.fov) / 2)
    half_w = half_h * width / height
    return f64(np.concatenate([eye, fwd, right * half_w, true_up * half_h]))


def light_size(light):
    """(first, second) edge lengths: ``size`` is one number for a square
    light or a (first, second) pair for a rectangle."""
    size = light.size
    if np.ndim(size) == 0:
        return float(size), float(size)
    first, second = size
    return float(first), float(second)


def light_buffers(scene, shadows, light_samples):
    """Area lights are sampled only with soft shadows; otherwise every light
    is a point at its centre, one shadow ray (hard) or none."""
    pos, col, us, vs, ns = [], [], [], [], []
    for L in scene.lights:
        p = np.asarray(L.position, dtype=float)
        if not np.all(np.isfinite(p)):
            raise RaytraceError("light position must be finite")
        pos.append(p)
        col.append(np.asarray(L.color, dtype=float) * L.intensity)
        size_u, size_v = light_size(L)
        if shadows == "soft" and size_u > 0 and size_v > 0:
            n = np.asarray(L.direction, dtype=float)
            n /= np.linalg.norm(n)
            a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
            u = np.cross(n, a)
            u /= np.linalg.norm(u)
            v = np.cross(n, u)
            us.append(u * size_u)
            vs.append(v * size_v)
            ns.append(L.samples or light_samples)
        else:
            us.append(np.zeros(3))
            vs.append(np.zeros(3))
            ns.append(1)
    from raytrace.kernels.sampling import sample_hashes
    samples = i64(ns)
    return Lights(pos=f64(pos, 3), color=f64(col, 3), u=f64(us, 3), v=f64(vs, 3),
                  samples=samples, side=i64([math.isqrt(int(n)) for n in samples]),
                  hashes=sample_hashes(int(samples.max(initial=1))))


def shadow_record(shadows, pattern):
    """The kernel's shadow-mode record: soft shadows are a type of their
    own (their sampling compiles only when used); none and hard share one."""
    from raytrace.kernels.render import PointShadows, SoftShadows
    from raytrace.kernels.sampling import PATTERN_NAMES
    if shadows in ("none", "hard"):
        return PointShadows(cast=shadows == "hard")
    return SoftShadows(pattern=int(PATTERN_NAMES[pattern]))


def texture_record(texture_filter, width, height, spp, geo):
    """The kernel's texture record: MeshTextures where a mesh has vertex
    colours or an image texture (their lookups compile only then).  A
    box-filtered texture is averaged over one camera sample's share of the
    pixel, 1/sqrt(spp) of its width and height (the screen spans 2 units in
    each direction), as pbrt scales its ray differentials."""
    from raytrace.kernels.render import MeshTextures, Textures
    share = 1.0 / math.sqrt(spp)
    kind = MeshTextures if len(geo.vtx_color) or len(geo.vtx_uv) else Textures
    return kind(filtered=texture_filter != "none", step_x=2.0 / width * share,
                step_y=2.0 / height * share)


def integrator_of(opts, scene):
    """The render's integrator: the option, else the scene file's, else
    whitted."""
    return opts.integrator or getattr(scene, "integrator", None) or "whitted"


# --max-depth's default per integrator.  Whitted: 5 mirror and glass
# bounces.  Path: 16, the most the option allows; Russian roulette ends
# nearly every path before it, and 5 cut 1.6% of the Cornell box's light
# (docs/pathtracer.md).
MAX_DEPTH = {"whitted": 5, "path": 16}


def max_depth_of(opts, scene):
    """The render's --max-depth: the option, else its integrator's default."""
    return MAX_DEPTH[integrator_of(opts, scene)] if opts.max_depth is None else opts.max_depth


def check_path_options(opts, scene):
    """Raise OptionError for an option the path tracer cannot honour: it
    needs its shadow rays (a light sample unchecked for occlusion is
    light through walls), and takes one light sample per light at each
    bounce (more per pixel: --spp)."""
    if integrator_of(opts, scene) != "path":
        if opts.sampler != BY_NAME["sampler"].default:
            _path_refuses("sampler", f"sampler {opts.sampler!r} is the path tracer's (add "
                                     "--integrator path)")
        return
    if opts.shadows == "none":
        _path_refuses("shadows", "shadow mode 'none' cannot be path traced: its light samples "
                                 "need their shadow rays (use hard or soft)")
    if opts.light_samples != BY_NAME["light_samples"].default:
        _path_refuses("light_samples", "light samples cannot be set for the path tracer: it takes "
                                       "one per light at each bounce (for more, raise --spp)")
    for k, light in enumerate(scene.lights):
        if light.samples and opts.shadows == "soft":
            raise RaytraceError(f"{light.where or f'light {k}'}: its samples cannot be set for the "
                                "path tracer (one light sample per light at each bounce; for "
                                "more, raise --spp)")


def _path_refuses(name, why):
    exc = OptionError(why)
    exc.flag = BY_NAME[name].flag
    raise exc


def bounce_record(scene, max_depth, integrator="whitted", geo=None, sampler="independent"):
    """The kernel's mirror-and-glass record: Bounces only when a material
    reflects or transmits, so other scenes compile and cast no such rays;
    the path tracer's record (Paths, with its emitters) for ``path``."""
    from raytrace.kernels.render import Bounces, NoBounces
    from raytrace.scene.model import Mesh, Plane, Sphere
    if integrator == "path":
        from raytrace.renderer.emitters import path_record
        return path_record(geo, int(max_depth), sampler=sampler)
    if any(o.material.bounces() for o in scene.objects if isinstance(o, (Mesh, Sphere, Plane))):
        return Bounces(max_depth=int(max_depth))
    return NoBounces()


def aov_buffers(width, height, enabled):
    """Per-pixel AOV buffers (raytrace/renderer/aov.py), or empty ones (no rows)
    when they are not wanted: the same kernel skips their stores."""
    from raytrace.kernels.render import Aovs
    if not enabled:
        # Empty buffers of the same types: one kernel serves both, and the
        # writes it skips cost nothing next to a pixel's rays.
        return Aovs(depth=np.zeros((0, 0), np.float32), normal=np.zeros((0, 0, 3), np.float32),
                    primid=np.zeros((0, 0), np.int64), cost=np.zeros((0, 0), np.int64))
    return Aovs(depth=np.full((height, width), np.inf, np.float32),
                normal=np.zeros((height, width, 3), np.float32),
                primid=np.full((height, width), -1, np.int64),
                cost=np.zeros((height, width), np.int64))


def to_srgb8(linear, threads=1):
    """Clamp and encode with the sRGB curve (IEC 61966-2-1).

    A band of rows at a time: on the whole image the float temporaries
    take several times what the memory check in validate() counts, so a
    big render that passed the check could fail here, after all its work.
    The bands go to ``threads`` threads (NumPy lets go of the GIL in its
    loops): on one thread, the 640x480 teapot's took 5 ms of the 30 its
    render() took.
    """
    out = np.empty(linear.shape, np.uint8)
    rows = len(linear)
    band = max(1, SRGB_BAND_VALUES // max(1, linear[0].size)) if rows else 1
    band = max(1, min(band, -(-rows // (2 * threads))))     # two bands a thread at least
    starts = range(0, rows, band)

    def encode(share):
        for y0 in share:
            c = np.clip(linear[y0:y0 + band], 0.0, 1.0)
            s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
            out[y0:y0 + band] = (s * 255.0 + 0.5).astype(np.uint8)
    parts = max(1, min(threads, len(starts)))
    if parts == 1:
        encode(starts)
    else:
        from raytrace.kernels.threads import run_on_threads
        run_on_threads([functools.partial(encode, starts[k::parts]) for k in range(parts)])
    return out


@dataclass
class Setup:
    """What every frame and tile of a render shares, made once: the
    flattened scene, its structure, lights and the kernel's mode records.
    Only the camera differs between frames, and only rows between tiles."""
    opts: object
    width: int
    height: int
    threads: int
    geo: object
    acc: object
    lights: object
    shadows: object
    textures: object
    bounces: object
    background: np.ndarray
    info: dict
    times: dict                  # setup_s, build_s, and the builder's load in compile_s
    peaks: dict                  # peak memory (MB) after each phase: load, flatten, build

    def payload(self):
        """The arrays and records a worker needs (frames/distributed.py): no
        options object, no callables, so it pickles small and safe."""
        return Payload(self.geo, self.acc, self.lights, self.shadows, self.textures, self.bounces,
                       self.background, self.width, self.height, int(self.opts.spp),
                       int(self.opts.seed))


class Payload(NamedTuple):
    """What a band of rows is rendered from (render_band), in any process."""
    geo: object
    acc: object
    lights: object
    shadows: object
    textures: object
    bounces: object
    background: np.ndarray
    width: int
    height: int
    spp: int
    seed: int


def options_with(opts, kw):
    """``opts`` (or the defaults) with the keyword overrides ``kw``, each checked by name."""
    opts = opts or RenderOptions()
    for k, v in kw.items():
        if not hasattr(opts, k):
            raise OptionError(f"render() got an unknown option {k!r}")
        setattr(opts, k, v)
    return opts


def peak_memory_mb():
    """This process's peak resident memory so far, in MB (0 where unknown).
    Linux: VmHWM, this program's own; getrusage's ru_maxrss also counts the
    parent's memory at the fork (a render started by a big test process)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 2**10                  # kB
    except (OSError, ValueError):
        pass
    try:
        import resource
    except ImportError:          # Windows
        return 0.0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 2**10   # bytes / KiB


def prepare(scene, opts, drop_meshes=False):
    """Validate, flatten and build: a Setup for any number of frames.
    drop_meshes: the caller will not use the scene's meshes again (the
    command's own scene, read from a file), so they leave the scene once
    flattened, before the build, which is the peak (their vertices and
    faces; the flattened scene holds what the render needs)."""
    width, height = (int(n) for n in validate(opts, scene))
    peaks = {"load": peak_memory_mb()}
    t_start = time.perf_counter()
    import numba  # deferred: `raytrace scenes` and --help never pay for it

    from raytrace.accel.registry import BUILD_OPTIONS, build_structure, get
    from raytrace.scene.flatten import flatten, load_corners, tiny_geometry

    threads = int(opts.threads or numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(threads)
    t_corners = load_corners(scene)     # compile time, not flattening's
    geo, obj_ranges, info = flatten(scene)
    lights = light_buffers(scene, opts.shadows, opts.light_samples)
    background = f64(scene.background)
    shadows = shadow_record(opts.shadows, opts.pattern)
    textures = texture_record(opts.texture_filter, width, height, int(opts.spp), geo)
    bounces = bounce_record(scene, max_depth_of(opts, scene), integrator_of(opts, scene), geo,
                            opts.sampler)
    t_import = time.perf_counter() - t_start - t_corners
    peaks["flatten"] = peak_memory_mb()
    if drop_meshes:
        from raytrace.scene.model import Mesh
        scene.objects = [o for o in scene.objects if not isinstance(o, Mesh)]

    build_opts = {name: getattr(opts, name) for name in BUILD_OPTIONS}
    # Loading (or compiling) the builder is compile time, not build time.
    t_load = t_corners + get(opts.accel).load(tiny_geometry(), n_bounded(geo), **build_opts)
    acc, t_build = build_structure(opts.accel, geo, obj_ranges, **build_opts)
    peaks["build"] = peak_memory_mb()
    return Setup(opts=opts, width=width, height=height, threads=threads, geo=geo, acc=acc,
                 lights=lights, shadows=shadows, textures=textures, bounces=bounces,
                 background=background, info=info,
                 times={"setup_s": t_import, "build_s": t_build, "compile_s": t_load},
                 peaks=peaks)


def render_band(payload, cam, y0, y1, threads, aovs=None, image=None, stats_rows=None, row0=None,
                load=True, reuse=None):
    """Rows y0 .. y1 of the frame seen from ``cam`` (camera_buffer), from a
    Setup's payload: (linear float32 rows, counter rows, compile_s,
    render_s).  Without buffers, the band gets its own (rows y0 .. y1 only:
    a tile of a poster costs its own rows, not the poster's).  ``load``:
    first compile or load the kernel, timed apart (compile_s; 0 without).
    ``reuse``: as waves.render_rows takes it, for bands of one render into
    the same buffers."""
    from raytrace.kernels.counters import N_COUNTERS
    from raytrace.kernels.render import Band, Lighting, Render
    from raytrace.kernels.waves import load_own_stages, load_rays, load_shading, render_rows
    p = payload
    width = p.width
    if image is None:
        row0 = y0
        image = np.empty((y1 - y0, width, 3), np.float32)
        stats_rows = np.zeros((y1 - y0, N_COUNTERS), np.int64)
    if aovs is None:
        aovs = aov_buffers(width, p.height, False)
    # Plain Python scalars only: a NumPy integer or a bool where an int is
    # expected would compile the kernel again for that type.
    render = Render(lighting=Lighting(p.geo, p.acc, p.lights, p.shadows, int(p.seed)), cam=cam,
                    textures=p.textures, bounces=p.bounces, background=p.background,
                    width=int(width), height=int(p.height), spp=int(p.spp))
    band = Band(image=image, aovs=aovs, stats_rows=stats_rows, row0=int(row0))
    clock = np.zeros(1, np.int64)    # the strips' tickets (kernels/waves.py)
    # An empty band compiles the kernel (or loads it from Numba's cache)
    # without rendering anything, so that time is reported apart.
    t_compile = 0.0
    if load:
        from raytrace.renderer import ahead
        t0 = time.perf_counter()
        # A first run's second process compiles the ray kernels or the
        # shading stages (renderer/ahead.py); this one the other part.
        rays_ahead = ahead.compiles_rays()
        if not rays_ahead:
            load_rays(render, band)
        load_own_stages(render, band, ahead.shades_bounces_here())
        if rays_ahead:
            load_shading(render, band)
        ahead.wait()
        if rays_ahead:
            load_rays(render, band)
        else:
            load_shading(render, band)
        t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    clock[0] = 0
    render_rows(render, band, int(y0), int(y1), int(threads), clock, reuse)
    return image, stats_rows, t_compile, time.perf_counter() - t0


def render(scene, opts=None, *, drop_meshes=False, **kw):
    """Render a Scene; returns a RenderResult (image, linear, stats, aovs).

    Keyword arguments override fields of RenderOptions, e.g.
    ``render(scene, accel="bvol", shadows="soft", width=320, height=240)``.
    drop_meshes: as for prepare (the command's scene only).
    """
    from raytrace.renderer.firstrun import expecting_render
    opts = options_with(opts, kw)
    with expecting_render(scene, opts, integrator_of(opts, scene)):
        return _render(scene, opts, drop_meshes)


def _render(scene, opts, drop_meshes):
    from raytrace.kernels.counters import N_COUNTERS
    from raytrace.renderer import ahead
    from raytrace.renderer.stats import counters_from_rows, derive
    validate(opts, scene)
    # A first run: part of the kernels compiles beside prepare (renderer/ahead.py).
    ahead.start(scene, integrator_of(opts, scene), opts.accel, opts.shadows)
    setup = prepare(scene, opts, drop_meshes)
    cam = camera_buffer(scene.camera, setup.width, setup.height)
    width, height = setup.width, setup.height
    image = np.zeros((height, width, 3), np.float32)
    stats_rows = np.zeros((height, N_COUNTERS), np.int64)
    aovs = aov_buffers(width, height, opts.aov)
    payload = setup.payload()

    # Bands of rows let a progress bar move.  A band is one kernel call
    # whose threads take strips of TILE rows by ticket, and its last strip
    # leaves the other threads idle, so a band holds at least 4 strips a
    # thread (docs/benchmarks.md, "Renderer").
    band = height
    if opts.progress:
        from raytrace.kernels.wavefront import TILE
        band = max(4 * TILE * setup.threads, -(-height // (32 * TILE)) * TILE)
    t_compile = t_render = 0.0
    reuse = {}      # the threads' stages, made at the first band (waves.render_rows)
    for y0 in range(0, height, band):
        y1 = min(height, y0 + band)
        _, _, tc, tr = render_band(payload, cam, y0, y1, setup.threads, aovs, image,
                                   stats_rows, 0, load=y0 == 0, reuse=reuse)
        t_compile += tc
        t_render += tr
        if opts.progress:
            opts.progress(y1, height)
    stats = base_stats(setup, scene.name)
    stats["time"] = {"render_s": t_render, "build_s": setup.times["build_s"],
                     "compile_s": t_compile + setup.times["compile_s"],
                     "setup_s": setup.times["setup_s"]}
    stats["counters"] = counters_from_rows(stats_rows)
    stats["peak_memory_mb"] = {**setup.peaks, "render": peak_memory_mb()}
    result_aovs = aovs._asdict() if opts.aov else {}
    return RenderResult(image=to_srgb8(image, setup.threads), linear=image, stats=derive(stats),
                        aovs=result_aovs, structure=setup.acc)


def base_stats(setup, scene_name):
    """The statistics that describe the render's setting (no times, no counters)."""
    from raytrace.accel.registry import BUILD_OPTIONS, get
    opts = setup.opts
    return {
        "scene": scene_name, "accel": opts.accel, "shadows": opts.shadows,
        "light_samples": int(setup.lights.samples.max()) if len(setup.lights.samples) else 0,
        **{name: getattr(opts, name) for name in BUILD_OPTIONS},
        "pattern": opts.pattern, "texture_filter": opts.texture_filter,
        "max_depth": getattr(setup.bounces, "max_depth", None), "width": setup.width,
        "integrator": "path" if hasattr(setup.bounces, "emit_cdf") else "whitted",
        "height": setup.height, "spp": opts.spp, "seed": opts.seed, "threads": setup.threads,
        **setup.info,
        "time": {},
        "counters": {},
        "structure": get(opts.accel).statistics(
            setup.acc, setup.geo.tri_v0.shape[0] + setup.geo.sph_center.shape[0]),
    }

