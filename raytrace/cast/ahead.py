"""A first ray query's kernel compiled in a second process
(kernels/ahead.py) while this one compiles the structure's builder and
builds: the kernel's types are known before the build (each structure's
``empty`` layout), so the two compiles overlap.

Only for closest and any hit (``cast_rays``, ``occluded``), and only on a
first run: no closest or any-hit kernel of any structure in the cache
(a glob), or a first query of a structure whose builder compiles long
(Structure.first_rays_ahead: the kd-tree after another structure).  The
second process compiles exactly the kernel the call will run (the
structure's, with packets or not by the number of rays, kernels/cast.py)
and nothing else.
"""
from raytrace.kernels import ahead

_KEY = "query"
# The kernels' cache index names (kernels/cast.py's two block factories;
# Numba drops a qualified name's "<" and ">").
_INDEX = {"closest": "cast._closest_kernel.locals.block-*.nbi",
          "occluded": "cast._occluded_kernel.locals.block-*.nbi"}


def start(accel, query, n_rays):
    """Start compiling ``query``'s kernel (closest or occluded) for
    ``accel`` and a call of ``n_rays`` rays, if none is cached yet."""
    if not ahead.worthwhile(_KEY):
        return
    from raytrace.accel.registry import get
    from raytrace.kernels.cachedir import kernel_cached
    if kernel_cached(_INDEX[query]) and not get(accel).first_rays_ahead():
        return
    from raytrace.kernels.cast import PACKET_MIN
    ahead.launch(_KEY, "raytrace.cast.precompile", [accel, query, int(n_rays >= PACKET_MIN)])


def wait():
    """Wait for the second process, if one was started, and adopt what it
    compiled."""
    ahead.wait(_KEY)


def cancel():
    """Stop the second process, if one runs (the build failed)."""
    ahead.stop(_KEY)
