"""A first render's shading stages compiled in a second process
(kernels/ahead.py), while this one loads the scene, compiles the
structure's builder and ray kernels and builds.

Only on a first run: nothing of the shading stages in the kernel cache
(kernels/cachedir.render_kernel_cached, a glob).  The second process
compiles the stages for a tiny scene of the same kind (scene/kinds.py: the
same types, so the same kernels); the render waits for it (``wait``) before
its first wave.
"""
from raytrace.kernels import ahead

_KEY = "render"


def start(scene, integrator="whitted"):
    """Start compiling the stages ``scene``'s render will use (the path
    tracer's for ``integrator`` "path"), if this is a first run on a
    machine with cores to spare."""
    if not ahead.worthwhile(_KEY):
        return
    from raytrace.kernels.cachedir import kernel_cached, render_kernel_cached
    path = integrator == "path"
    if kernel_cached("pathtrace.run_path_shade-*.nbi") if path else render_kernel_cached():
        return
    from raytrace.scene.kinds import scene_kind
    textures, mirrors = scene_kind(scene)
    ahead.launch(_KEY, "raytrace.renderer.precompile", [int(textures), int(mirrors), int(path)])


def wait():
    """Wait for the second process, if one was started, and adopt what it
    compiled."""
    ahead.wait(_KEY)
