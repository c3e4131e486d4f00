"""A first render's kernels compiled in part in a second process
(kernels/ahead.py), while this one loads the scene, compiles the
structure's builder and builds.

Only on a first run: nothing of the shading stages in the kernel cache
(kernels/cachedir.render_kernel_cached, a glob).  For a structure with
packet kernels, a scene without mirrors or glass, and no ray kernel in
the cache, the second process compiles the structure's ray kernels (for
its empty layout: the types of every layout it builds) and this one the
shading stages after its build; otherwise the second process compiles the
stages (for a tiny scene of the same kind, scene/kinds.py: the same types,
so the same kernels).  Split so, the two compiles take about as long: a
first BVH teapot's builder and build took 2 s here, its stages 4.5 s and
its packet ray kernels 6 s; mirrors' and glass's stages take 6 s, the
other structures' one-ray kernels half as long as the BVH's, and the
grid's and the kd-tree's builders longer (docs/benchmarks.md, "Camera rays
through packets").  Where the stages are cached but a structure whose
builder compiles long has no traversal there (Structure.first_rays_ahead:
the kd-tree after another structure), the second process compiles its ray
kernels while this one compiles its builder.  Where the stages are cached
but a mirror scene's are not, the second process compiles the mirror
entry's steps but shading (bounces.run_bounce_stage) while this one
compiles their shading (run_bounce_shade): 1.0 and 1.6 s, where the two
in one entry took 2.5 (docs/benchmarks.md, "The mirrors' two entries").
The render waits for the second process (``wait``) before its first wave.
"""
from raytrace.kernels import ahead

_KEY = "render"
# The ray kernels' cache index (kernels/cast.py's closest-hit block
# factory; Numba drops a qualified name's "<" and ">").
_RAYS_INDEX = "cast._closest_kernel.locals.block-*.nbi"
_BOUNCE_INDEX = "bounces.run_bounce_shade-*.nbi"
_part = {"rays": False, "bounce": False}


def start(scene, integrator="whitted", accel="bvh", shadows="hard"):
    """Start compiling part of what ``scene``'s render will use (the path
    tracer's shading entry for ``integrator`` "path"; structure
    ``accel``'s ray kernels or the shading stages otherwise, the any-hit
    one if ``shadows`` are cast), if this is a first run on a machine with
    cores to spare."""
    if not ahead.worthwhile(_KEY):
        return
    from raytrace.accel.registry import get
    from raytrace.kernels.cachedir import kernel_cached, render_kernel_cached
    from raytrace.scene.kinds import scene_kind
    path = integrator == "path"
    stages = kernel_cached("pathtrace.run_path_shade-*.nbi") if path else render_kernel_cached()
    textures, mirrors = scene_kind(scene)
    if stages and (path or not get(accel).first_rays_ahead()):
        if mirrors and not path and not kernel_cached(_BOUNCE_INDEX):
            # The shading stages cached, mirrors' and glass's not: their
            # steps but shading compile there, their shading here.
            ahead.launch(_KEY, "raytrace.renderer.precompile",
                         [int(textures), 1, 0, "-", shadows, 0])
            _part["bounce"] = True
        return
    # The stages cached: the structure's rays (its builder compiles here).
    rays = stages or (not (path or mirrors) and not kernel_cached(_RAYS_INDEX)
                      and _has_packets(accel))
    ahead.launch(_KEY, "raytrace.renderer.precompile",
                 [int(textures), int(mirrors), int(path), accel if rays else "-", shadows])
    _part["rays"], _part["bounce"] = rays, False


def _has_packets(accel):
    """Whether structure ``accel`` traces packets (importing it)."""
    from raytrace.accel.registry import get
    from raytrace.kernels.query import has_packets
    return has_packets(get(accel).empty_layout())


def compiles_rays():
    """Whether a second process started by ``start`` is compiling the ray
    kernels (so this process compiles the stages), not yet waited for."""
    return _part["rays"] and ahead.pending(_KEY)


def shades_bounces_here():
    """Whether a second process started by ``start`` compiles the mirror and
    glass entry's other steps while this process compiles its shading
    (bounces.run_bounce_shade), not yet waited for."""
    return _part["bounce"] and ahead.pending(_KEY)


def wait():
    """Wait for the second process, if one was started, and adopt what it
    compiled."""
    ahead.wait(_KEY)
