"""The two questions every structure answers (pbrt's Intersect and
IntersectP): the closest hit of a ray, and whether anything blocks it.

A structure is a type: its layout, a namedtuple class of its own
(``raytrace.accel.<name>``).  Each structure's kernel module registers its
traversal for that class, and a kernel calling ``closest_hit(geo, acc,
...)`` is compiled once per layout type with that structure's traversal
chosen at compile time (Numba's ``@overload``): a BVH render never
compiles, or branches over, the grid's code.
"""
from numba.core.errors import TypingError
from numba.extending import overload

from .jit import OVERLOAD
from .prims import planes_closest, planes_occluded

# layout class -> (closest, any_hit): compiled functions (geo, acc, ray,
# t_max, cnt) -> Hit; any_hit returns the first hit it finds.
_TRAVERSALS = {}


def register(layout, closest, any_hit):
    """Make ``layout`` (a structure's namedtuple class) queryable."""
    _TRAVERSALS[layout] = (closest, any_hit)


def _traversal(acc):
    cls = getattr(acc, "instance_class", None)
    if cls not in _TRAVERSALS:
        raise TypingError(f"no traversal registered for structure layout {acc}")
    return _TRAVERSALS[cls]


def closest_hit(geo, acc, ray, t_max, cnt):
    """Closest hit with 0 < t < t_max, planes included: a Hit (prim -1 on a
    miss).  cnt: the caller's counter row, never shared between threads.
    Compiled code only."""
    raise NotImplementedError("closest_hit is called from compiled kernels only")


def occluded(geo, acc, ray, t_max, cnt):
    """Whether anything is hit with 0 < t < t_max; stops at the first.
    Compiled code only."""
    raise NotImplementedError("occluded is called from compiled kernels only")


@overload(closest_hit, jit_options=OVERLOAD)
def _closest_hit(geo, acc, ray, t_max, cnt):
    closest = _traversal(acc)[0]

    def impl(geo, acc, ray, t_max, cnt):
        return planes_closest(geo, ray, t_max, closest(geo, acc, ray, t_max, cnt), cnt)
    return impl


@overload(occluded, jit_options=OVERLOAD)
def _occluded(geo, acc, ray, t_max, cnt):
    any_hit = _traversal(acc)[1]

    def impl(geo, acc, ray, t_max, cnt):
        # Planes first: one test each, and the ground blocks many shadow rays.
        if planes_occluded(geo, ray, t_max, cnt):
            return True
        return any_hit(geo, acc, ray, t_max, cnt).prim >= 0
    return impl
