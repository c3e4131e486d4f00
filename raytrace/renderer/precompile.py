"""The second process of renderer/ahead.py: compile a render's shading
stages for a tiny scene of a kind, and nothing else (no structure is
built).  Its own module, run with ``python -m``, so that nothing imports
it and the driver and ahead.py import each other nowhere.

    python -m raytrace.renderer.precompile TEXTURES MIRRORS PATH     (0 or 1 each)
"""
import sys

import numpy as np


def load_stages(scene, opts=None):
    """Compile (or load) the shading stages a render of ``scene`` uses, and
    nothing else: no structure is built (renderer/ahead.py)."""
    from raytrace.kernels.buffers import f64
    from raytrace.kernels.counters import N_COUNTERS
    from raytrace.kernels.render import Band, Lighting, Render
    from raytrace.kernels.waves import load_shading
    from raytrace.renderer.driver import (
        RenderOptions,
        aov_buffers,
        bounce_record,
        camera_buffer,
        integrator_of,
        light_buffers,
        max_depth_of,
        shadow_record,
        texture_record,
        validate,
    )
    from raytrace.scene.flatten import flatten
    opts = opts or RenderOptions()
    width, height = (int(n) for n in validate(opts, scene))
    geo, _, _ = flatten(scene)
    lighting = Lighting(geo, None, light_buffers(scene, opts.shadows, opts.light_samples),
                        shadow_record(opts.shadows, opts.pattern), int(opts.seed))
    render = Render(lighting=lighting, cam=camera_buffer(scene.camera, width, height),
                    textures=texture_record(opts.texture_filter, width, height, int(opts.spp), geo),
                    bounces=bounce_record(scene, max_depth_of(opts, scene), integrator_of(opts, scene),
                                          geo, opts.sampler),
                    background=f64(scene.background),
                    width=width, height=height, spp=int(opts.spp))
    band = Band(image=np.empty((0, width, 3), np.float32), aovs=aov_buffers(width, height, False),
                stats_rows=np.zeros((0, N_COUNTERS), np.int64), row0=0)
    load_shading(render, band)


def main(textures, mirrors, path=False):
    from raytrace.renderer.driver import RenderOptions
    from raytrace.scene.kinds import tiny_scene
    # The path tracer's shading entry (the render compiles its other one
    # meanwhile): the types `raytrace warmup --with path` compiles for (a
    # tiny scene with mirrors, one sample).
    opts = RenderOptions(integrator="path", spp=1) if path else None
    load_stages(tiny_scene(textures, mirrors or path), opts)


if __name__ == "__main__":
    main(*(bool(int(a)) for a in sys.argv[1:4]))
