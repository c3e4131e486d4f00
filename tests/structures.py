"""Every acceleration structure; tests parametrize over this list so a new
structure is covered by the same tests the day it is added."""
from raytrace.buffers import ACCEL_NAMES

STRUCTURES = list(ACCEL_NAMES)
