"""The renderer's Python side: threads take strips of TILE rows by ticket
(so a thread's image rows and counter rows are its own), and each strip
goes through the stages a wave at a time: the shading stages' compiled
entry (wavefront.py, or bounces.py for mirrors and glass) and the
structure's ray kernels (cast.py's, shared with the ray-casting API),
called in turn."""
import functools
import threading

import numpy as np

from raytrace.kernels import bounces
from raytrace.kernels.cast import closest_rays, occluded_rays, ray_scene, ray_tally
from raytrace.kernels.entry import Entry
from raytrace.kernels.packed import packed_once
from raytrace.kernels.render import NoBounces, Paths, SoftShadows
from raytrace.kernels.threads import run_on_threads
from raytrace.kernels.wavefront import (
    CAMERA,
    FINISH,
    HARD_SHADOWS,
    NO_SHADOWS,
    SHADE,
    SHADOW_BATCH,
    TILE,
    Shading,
    run_stage,
    shadow_buffers,
    stage_records,
    wave_buffers,
    wave_squares,
)


class _Stages:
    """A thread's buffers and the stage calls of one wave (direct light)."""

    def __init__(self, shading, textures, acc, band):
        self.shading, self.textures, self.acc, self.band = shading, textures, acc, band
        self.scene = ray_scene(shading.geo, acc)
        spp = shading.spp
        self.squares = wave_squares(shading.width, spp)
        self.wave = wave_buffers(self.squares * TILE * TILE * spp)
        # Room for a whole wave's shadow rays and light entries, up to
        # SHADOW_BATCH (and at least one hit's): no bigger buffers than
        # the scene's lights can fill.
        samples = shading.lights.samples
        most = int(np.maximum(samples, 1).sum()) if len(samples) else 0
        rays = len(self.wave.x)
        self.shadow = shadow_buffers(max(min(SHADOW_BATCH, rays * most), most),
                                     max(min(SHADOW_BATCH, rays * len(samples)), len(samples)))
        # With AOVs each camera ray counts into a row of its own, summed
        # per pixel for the cost AOV; otherwise straight into its image row.
        self.counters = self.wave.cnt if len(band.aovs.cost) else band.stats_rows
        self.tally = ray_tally(acc, self.counters is self.wave.cnt)
        self.views = {}
        # The thread's buffers keep their types: each kernel through its
        # compiled entry (entry.py), not the dispatcher, after the first call.
        self.entries = {}
        self.run_stage = Entry(run_stage)
        self.records = stage_records(shading, textures, self.wave, self.shadow, self.counters,
                                     band)

    def strip(self, top, y_end):
        """The strip of TILE rows from ``top``, a wave of squares at a time."""
        n_cols = -(-self.shading.width // TILE)
        for q0 in range(0, n_cols, self.squares):
            self.trace(top, y_end, q0, min(q0 + self.squares, n_cols))

    def camera(self, top, y_end, q0, q1):
        """The wave's camera rays and their closest hits; returns how many."""
        wave = self.wave
        n, _ = self.run_stage(CAMERA, self.records,
                              (top, y_end, q0, q1, int(self.counters is wave.cnt)))
        if n not in self.views:
            self.views[n] = ((wave.origins[:n], wave.dirs[:n], wave.t_min[:n], wave.t_max[:n]),
                             (wave.hit_t[:n], wave.hit_prim[:n], wave.hit_u[:n], wave.hit_v[:n]),
                             wave.row[:n])
        rays, hits, rows = self.views[n]
        closest_rays(self.scene, rays, hits, self.counters, rows, self.entries, self.tally)
        return n

    def occlude(self, m):
        """Trace the first m shadow rays."""
        s = self.shadow
        occluded_rays(self.scene, (s.origins[:m], s.dirs[:m], s.t_min[:m], s.t_max[:m]),
                      s.blocked[:m], self.counters, s.row[:m], self.entries, self.tally)

    def trace(self, top, y_end, q0, q1):
        n = self.camera(top, y_end, q0, q1)
        k = 0
        while k < n:
            k1, m = self.run_stage(SHADE, self.records, (k, n, 0, 0, 0))
            if m:
                self.occlude(m)
            self.run_stage(FINISH, self.records, (k, k1, n, 0, 0))
            k = k1


class _Generations(_Stages):
    """_Stages for a render with mirror and glass rays: each wave's rays
    generation by generation (bounces.py)."""

    def __init__(self, shading, textures, acc, band, max_depth):
        super().__init__(shading, textures, acc, band)
        self.max_depth = max_depth
        size = len(self.wave.x)
        self.gens = [bounces.generation_buffers(size), bounces.generation_buffers(2 * size)]
        self.light = bounces.light_buffers(2 * size, size)
        self.run_bounce_stage = Entry(bounces.run_bounce_stage)
        self.run_bounce_shade = Entry(bounces.run_bounce_shade)
        self.bounce_records = {}

    def stage(self, step, bufs, args):
        """bounces.run_bounce_stage with this thread's records: packed once
        for each pair of generations (they take turns), again for buffers
        grown since."""
        gen, nxt, _, light = bufs
        records = packed_once(self.bounce_records, (id(gen), id(nxt), id(light)),
                              lambda: bounces.bounce_records(self.shading, self.textures,
                                                             self.wave, bufs, self.counters), 2)
        if step == bounces.SHADE:
            return self.run_bounce_shade(records, args)
        return self.run_bounce_stage(step, records, args)

    def trace(self, top, y_end, q0, q1):
        gen, nxt = self.gens
        own = int(self.counters is self.wave.cnt)
        n, _ = self.run_stage(CAMERA, self.records, (top, y_end, q0, q1, own))
        self.stage(bounces.FIRST, (gen, nxt, self.shadow, self.light), (n, 0, 0, 0, 0))
        p, c = n, 0
        while p:
            # Each ray spawns at most two and adds at most one contribution.
            if len(nxt.key) < 2 * p:
                nxt = bounces.generation_buffers(2 * p)
            if len(self.light.key) < c + p:
                self.light = _grown(self.light, 2 * (c + p))
            closest_rays(self.scene,
                         (gen.origins[:p], gen.dirs[:p], gen.t_min[:p], gen.t_max[:p]),
                         (gen.hit_t[:p], gen.hit_prim[:p], gen.hit_u[:p], gen.hit_v[:p]),
                         self.counters, gen.row[:p], self.entries, self.tally)
            bufs = (gen, nxt, self.shadow, self.light)
            i = q = 0
            while i < p:
                i1, m, q, c = self.stage(bounces.SHADE, bufs, (i, p, q, c, self.max_depth))
                if m:
                    self.occlude(m)
                c, _, _, _ = self.stage(bounces.FINISH, bufs, (i, i1, c, 0, 0))
                i = i1
            gen, nxt, p = nxt, gen, q
        self.gens = [gen, nxt]
        self.stage(bounces.GATHER, (gen, nxt, self.shadow, self.light), (n, c, 0, 0, 0))
        self.run_stage(FINISH, self.records, (n, n, n, 0, 0))   # no rays to light: stores the wave


def _grown(light, rows):
    """light with room for rows contributions (those made so far kept)."""
    bigger = bounces.light_buffers(rows, len(light.start) - 1)
    for old, new in zip(light[:3], bigger[:3]):
        new[:len(old)] = old
    return bigger


def _strips(stages, y0, y_end, clock, lock):
    """One thread's share: strips of TILE rows taken by ticket until none is
    left."""
    while True:
        with lock:
            ticket = int(clock[0])
            clock[0] += 1
        top = y0 + ticket * TILE
        if top >= y_end:
            return
        stages.strip(top, y_end)


def load_rays(render, band):
    """Compile (or load) the structure's ray kernels a render uses, on
    empty buffers: the closest-hit one and, if the render traces shadow
    rays, the any-hit one."""
    wave, shadow = wave_buffers(0), shadow_buffers(0, 0)
    geo, acc = render.lighting.geo, render.lighting.acc
    tally = ray_tally(acc, len(band.aovs.cost) > 0)      # as _Stages chooses
    scene = ray_scene(geo, acc)
    closest_rays(scene, (wave.origins, wave.dirs, wave.t_min, wave.t_max),
                 (wave.hit_t, wave.hit_prim, wave.hit_u, wave.hit_v), band.stats_rows, wave.row,
                 {}, tally)
    if casts_shadow_rays(render):
        occluded_rays(scene, (shadow.origins, shadow.dirs, shadow.t_min, shadow.t_max),
                      shadow.blocked, band.stats_rows, shadow.row, {}, tally)


def casts_shadow_rays(render):
    """Whether a render traces shadow rays: the path tracer's rays to the
    lights always, Whitted's unless shadows are off."""
    shadows = render.lighting.shadows
    return (isinstance(render.bounces, Paths) or isinstance(shadows, SoftShadows)
            or shadows.cast)


def load_own_stages(render, band, bounce_shade=False):
    """Compile (or load) what of a render's stages a first run compiles in
    this process while the second one compiles the rest (load_shading):
    the path tracer's entry for the camera, shadow rays' light and the
    film (path_waves.load); with ``bounce_shade``, the shading of mirrors'
    and glass's rays (bounces.run_bounce_shade, where the second process
    compiles their other steps: renderer/ahead.py)."""
    if isinstance(render.bounces, Paths):
        from raytrace.kernels import path_waves
        path_waves.load(_empty_stages(render, band), shade=False)
    elif bounce_shade and not isinstance(render.bounces, NoBounces):
        _load_bounces(_empty_stages(render, band), shade=True, rest=False)


def load_shading(render, band, bounce_shade=True):
    """Compile (or load) the shading stages' entries a render uses (run_stage,
    and bounces.run_bounce_stage and, with ``bounce_shade``,
    run_bounce_shade for mirrors and glass) on empty buffers;
    render.lighting.acc is not read (renderer/ahead.py compiles it
    in a process of its own, structure or none)."""
    stages = _empty_stages(render, band)
    if isinstance(render.bounces, Paths):
        from raytrace.kernels import path_waves
        path_waves.load(stages, shade=True)
        return
    run_stage(CAMERA, stage_records(stages.shading, stages.textures, stages.wave, stages.shadow,
                                    stages.counters, band), (0, 0, 0, 0, 0))
    if isinstance(stages, _Generations):
        _load_bounces(stages, shade=bounce_shade, rest=True)


def _empty_stages(render, band):
    """A render's stages as the loads above compile them: counting into
    band's rows, and (but the path tracer's) on empty wave and shadow
    buffers."""
    stages = _stages(render, band)
    stages.counters = band.stats_rows
    if not isinstance(render.bounces, Paths):
        stages.wave, stages.shadow = wave_buffers(0), shadow_buffers(0, 0)
    return stages


def _load_bounces(stages, shade, rest):
    """Compile (or load) the mirror and glass entries on _empty_stages'
    buffers: the shading's (``shade``), the other steps' (``rest``)."""
    gen = bounces.generation_buffers(0)
    records = bounces.bounce_records(stages.shading, stages.textures, stages.wave,
                                     (gen, gen, stages.shadow, bounces.light_buffers(0, 0)),
                                     stages.counters)
    if rest:
        bounces.run_bounce_stage(bounces.FIRST, records, (0, 0, 0, 0, 0))
    if shade:
        bounces.run_bounce_shade(records, (0, 0, 0, 0, 0))


def _stages(render, band):
    """The stages (and their buffers) of a Render: the path tracer's
    (path_waves.py, imported only then), _Generations for mirrors and
    glass, else _Stages."""
    lighting = render.lighting
    shadows = lighting.shadows
    mode = (shadows.pattern if isinstance(shadows, SoftShadows) else
            HARD_SHADOWS if shadows.cast else NO_SHADOWS)
    shading = Shading(lighting.geo, lighting.lights, mode, lighting.seed, render.cam,
                      render.background, render.width, render.height, render.spp)
    if isinstance(render.bounces, Paths):
        from raytrace.kernels.path_waves import PathStages
        return PathStages(shading, render.textures, lighting.acc, band, render.bounces)
    if isinstance(render.bounces, NoBounces):
        return _Stages(shading, render.textures, lighting.acc, band)
    return _Generations(shading, render.textures, lighting.acc, band,
                        int(render.bounces.max_depth))


def render_rows(render, band, y0, y1, n_threads, clock, reuse=None):
    """Render rows y0 .. y1-1 of a Render (render.py's record) into a Band:
    image row y is band.image[y - band.row0] (row0 = 0 for a whole-image
    buffer; a tile's own buffer starts at its first row), likewise its
    counter rows and AOVs (load_rays and load_shading compile or load the
    kernels first).  clock: a one-element int64 array, 0 at the call: the
    strips' tickets.  reuse: a dict the caller keeps across calls of one
    render into the same Band buffers (a progress bar's bands of rows),
    holding the threads' stages, their buffers and packed records, so each
    is made once a render, not once a band."""
    if y1 <= y0:
        return
    n_parts = max(1, min(n_threads, -(-(y1 - y0) // TILE)))
    stages = [] if reuse is None else reuse.setdefault("stages", [])
    while len(stages) < n_parts:
        stages.append(_stages(render, band))
    lock = threading.Lock()
    run_on_threads([functools.partial(_strips, s, y0, y1, clock, lock) for s in stages[:n_parts]])
