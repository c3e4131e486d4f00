"""Every acceleration structure; tests parametrize over this list so a new
structure is covered by the same tests the day it is added."""
from raytrace.structures import STRUCTURES as _REGISTRY

STRUCTURES = list(_REGISTRY)
