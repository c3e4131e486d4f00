"""The path tracer's Python side (``--integrator path``): a thread's
buffers and the calls of a wave's stages, generation by generation, as
waves._Generations runs mirrors and glass: the stages' compiled entries
(pathtrace.run_path_stage and run_path_shade) and the structure's two ray
kernels (cast.py), in turn.  Imported only by a path-traced render (waves._stages), so
nothing of it compiles for any other."""
from raytrace.kernels import pathtrace
from raytrace.kernels.cast import closest_rays, occluded_rays, ray_scene, ray_tally
from raytrace.kernels.entry import Entry
from raytrace.kernels.packed import packed_once
from raytrace.kernels.wavefront import CAMERA, SHADOW_BATCH, TILE, wave_buffers, wave_squares


class PathStages:
    """A thread's buffers and the stage calls of one wave of paths."""

    def __init__(self, shading, textures, acc, band, paths):
        self.shading, self.textures, self.acc, self.band = shading, textures, acc, band
        self.scene = ray_scene(shading.geo, acc)
        self.paths = paths
        self.squares = wave_squares(shading.width, shading.spp)
        self.wave = wave_buffers(self.squares * TILE * TILE * shading.spp)
        size = len(self.wave.x)
        # Each path spawns at most one ray; a hit casts a shadow ray to each
        # light and one to an emitter.
        self.gens = [pathtrace.path_buffers(size), pathtrace.path_buffers(size)]
        per_hit = len(shading.lights.pos) + 1
        self.shadow = pathtrace.light_ray_buffers(max(min(SHADOW_BATCH, size * per_hit),
                                                      per_hit))
        self.counters = self.wave.cnt if len(band.aovs.cost) else band.stats_rows
        self.tally = ray_tally(acc, self.counters is self.wave.cnt)
        self.entries = {}       # as waves._Stages'
        self.run_path_stage = Entry(pathtrace.run_path_stage)
        self.run_path_shade = Entry(pathtrace.run_path_shade)
        self.records = {}

    def stage(self, step, args):
        """pathtrace's entry for ``step`` (run_path_shade for SHADE, else
        run_path_stage) with this thread's records: packed once for each
        order of the generations (they take turns) and each entry."""
        shade = step == pathtrace.SHADE
        gen, nxt = self.gens
        records = packed_once(
            self.records, (shade, id(gen), id(nxt), id(self.wave), id(self.shadow)),
            lambda: pathtrace.path_records(self.shading, self.textures, self.paths, self.wave,
                                           (gen, nxt, self.shadow), self.counters,
                                           None if shade else self.band), 4)
        if shade:
            return self.run_path_shade(records, args)
        return self.run_path_stage(step, records, args)

    def strip(self, top, y_end):
        """The strip of TILE rows from ``top``, a wave of squares at a time."""
        n_cols = -(-self.shading.width // TILE)
        for q0 in range(0, n_cols, self.squares):
            self.trace(top, y_end, q0, min(q0 + self.squares, n_cols))

    def trace(self, top, y_end, q0, q1):
        own = int(self.counters is self.wave.cnt)
        n, _, _ = self.stage(CAMERA, (top, y_end, q0, q1, own))
        p = n
        scene, s = self.scene, self.shadow
        while p:
            gen = self.gens[0]
            closest_rays(scene, (gen.origins[:p], gen.dirs[:p], gen.t_min[:p], gen.t_max[:p]),
                         (gen.hit_t[:p], gen.hit_prim[:p], gen.hit_u[:p], gen.hit_v[:p]),
                         self.counters, gen.row[:p], self.entries, self.tally)
            i = q = 0
            while i < p:
                i, m, q = self.stage(pathtrace.SHADE, (i, p, q, 0, 0))
                if m:
                    occluded_rays(scene, (s.origins[:m], s.dirs[:m], s.t_min[:m], s.t_max[:m]),
                                  s.blocked[:m], self.counters, s.row[:m], self.entries,
                                  self.tally)
                    self.stage(pathtrace.FINISH, (m, 0, 0, 0, 0))
            self.gens.reverse()
            p = q
        self.stage(pathtrace.STORE, (n, 0, 0, 0, 0))


def load(stages, shade):
    """Compile (or load) on empty buffers the shading entry (``shade``:
    run_path_shade, which a first run compiles in the second process) or
    the other (run_path_stage, which it compiles in this one meanwhile)."""
    empty = pathtrace.path_buffers(0)
    stages.wave, stages.gens = wave_buffers(0), [empty, empty]
    stages.shadow = pathtrace.light_ray_buffers(0)
    stages.stage(pathtrace.SHADE if shade else CAMERA, (0, 0, 0, 0, 0))
