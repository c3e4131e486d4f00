"""Brute force needs no structure: its layout is empty."""
from collections import namedtuple

Brute = namedtuple("Brute", [])


def build(geo, obj_ranges, **_):
    return Brute()


def empty():
    """A layout of no primitives, of the built ones' types (cast/precompile.py)."""
    return Brute()


def statistics(brute, n_prims):
    return {"memory_bytes": 0, "bytes_per_primitive": 0.0}
