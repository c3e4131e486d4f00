"""Every acceleration structure; tests parametrize over this list so a new
structure is covered by the same tests the day it is added.

A render kernel is compiled for each structure and shading mode (soft
shadows, mirrors and glass: kernels/render.py), 10-18 s apiece cold on a
2-core machine, and a structure enters it only through its closest-hit and
any-hit queries.  So every structure's images are compared with hard
shadows (and no shadows), and its hits on the rays soft shadows, mirrors and
glass cast through the query API
(test_rays.test_secondary_rays_hit_alike_in_every_structure), while renders
with soft shadows or with mirrors and glass compare EVERY_MODE: brute force
and the default structure.  For all five that was 6 more kernels, about
100 s of a cold test suite's 2-core CPU time.
"""
from raytrace.accel.registry import DEFAULT
from raytrace.accel.registry import STRUCTURES as _REGISTRY

STRUCTURES = list(_REGISTRY)
EVERY_MODE = ["none", DEFAULT]
