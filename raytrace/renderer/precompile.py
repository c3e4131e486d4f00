"""The second process of renderer/ahead.py: compile a render's shading
stages for a tiny scene of a kind, or (given a structure) the structure's
ray kernels for its empty layout and that scene's geometry, and nothing
else (no structure is built).  Its own module, run with ``python -m``, so
that nothing imports it and the driver and ahead.py import each other
nowhere.

    python -m raytrace.renderer.precompile TEXTURES MIRRORS PATH ACCEL SHADOWS
    (the first three 0 or 1; ACCEL a structure's name, or - for the stages)
"""
import sys

import numpy as np


def load_kernels(scene, opts=None, accel=None, bounce_shade=True):
    """Compile (or load) the shading stages a render of ``scene`` uses or,
    given structure ``accel``, its ray kernels, and nothing else: no
    structure is built (renderer/ahead.py)."""
    from raytrace.accel.registry import get
    from raytrace.kernels.buffers import f64
    from raytrace.kernels.counters import N_COUNTERS
    from raytrace.kernels.render import Band, Lighting, Render
    from raytrace.kernels.waves import load_rays, load_shading
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
    acc = None if accel is None else get(accel).empty_layout()
    lighting = Lighting(geo, acc, light_buffers(scene, opts.shadows, opts.light_samples),
                        shadow_record(opts.shadows, opts.pattern), int(opts.seed))
    render = Render(lighting=lighting, cam=camera_buffer(scene.camera, width, height),
                    textures=texture_record(opts.texture_filter, width, height, int(opts.spp), geo),
                    bounces=bounce_record(scene, max_depth_of(opts, scene), integrator_of(opts, scene),
                                          geo, opts.sampler),
                    background=f64(scene.background),
                    width=width, height=height, spp=int(opts.spp))
    band = Band(image=np.empty((0, width, 3), np.float32), aovs=aov_buffers(width, height, False),
                stats_rows=np.zeros((0, N_COUNTERS), np.int64), row0=0)
    if acc is None:
        load_shading(render, band, bounce_shade)
    else:
        load_rays(render, band)


def main(textures, mirrors, path=False, accel=None, shadows="hard", bounce_shade=True):
    from raytrace.renderer.driver import RenderOptions
    from raytrace.scene.kinds import tiny_scene
    # The path tracer's shading entry (the render compiles its other one
    # meanwhile): the types `raytrace warmup --with path` compiles for (a
    # tiny scene with mirrors, one sample).
    opts = (RenderOptions(integrator="path", spp=1, shadows=shadows) if path
            else RenderOptions(shadows=shadows))
    load_kernels(tiny_scene(textures, mirrors or path), opts, accel, bounce_shade)


if __name__ == "__main__":
    main(*(bool(int(a)) for a in sys.argv[1:4]), None if sys.argv[4] == "-" else sys.argv[4],
         sys.argv[5], len(sys.argv) < 7 or sys.argv[6] == "1")
    from raytrace.kernels.ahead import finish
    finish()
