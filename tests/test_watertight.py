"""Watertightness (pbrt-v4's shapes_test): rays fired from inside a closed
mesh must hit it, every one, whatever the structure.

The Woop, Benthin & Wald (2013) test evaluates a shared edge's function
identically for both triangles, so a ray through an edge or a vertex
cannot slip between them.  These tests fire 10^6 random rays from inside
each mesh (2 x 10^5 for its copy moved 1e5 away), plus rays aimed exactly
at every vertex and edge midpoint, the places a non-watertight test leaks
(measured: a NumPy Moller-Trumbore test misses 700 of the 10,272 aimed
rays on the icosphere, 378 of 6,176 on the tilted box), and require zero
misses and results bit-identical to brute force.  The meshes are modest (320 and 192 triangles) so brute force
stays a second or two per 10^6 rays.
"""
import numpy as np
import pytest

from raytrace import cast_rays, occluded
from tests.structures import STRUCTURES

N_RAYS = 250_000
# Far from the origin the question is only whether rounding there opens an
# edge, which the aimed rays probe; fewer random ones keep the suite fast.
N_RAYS_SHIFTED = 100_000


def jittered_icosphere(subdivisions=2, jitter=0.05, seed=0):
    """A closed icosphere (320 triangles at 2 subdivisions) whose vertices
    are moved radially by up to +-jitter: every edge is a real crease."""
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    rng = np.random.default_rng(seed)
    v = m.vertices * (1.0 + rng.uniform(-jitter, jitter, (len(m.vertices), 1)))
    return np.ascontiguousarray(v), np.asarray(m.faces, np.int64)


def subdivided_box(levels=2, rotate=False):
    """A closed box from -1 to 1 (12 * 4^levels triangles); with rotate its
    faces are tilted off the axes, otherwise every triangle lies exactly
    on a face of the box's own bounding box."""
    import trimesh
    from trimesh.remesh import subdivide
    b = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    v, f = np.asarray(b.vertices), np.asarray(b.faces)
    for _ in range(levels):
        v, f = subdivide(v, f)
    if rotate:
        from raytrace.scene.transform import rotation
        v = v @ rotation((31.0, 17.0, 53.0)).T
    return np.ascontiguousarray(v), np.asarray(f, np.int64)


def edges(f):
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def check_closed(f):
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert np.all(counts == 2), "test mesh is not closed"


def inside_rays(v, f, shift, seed, n_random=N_RAYS):
    """n_random random rays from random points well inside, then rays from a
    few inside points aimed exactly at every vertex and every edge midpoint."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-0.5, 0.5, (n_random, 3))
    d = rng.normal(size=(n_random, 3))
    e = edges(f)
    targets = np.concatenate([v, 0.5 * (v[e[:, 0]] + v[e[:, 1]])])
    starts = np.concatenate([np.zeros((1, 3)), rng.uniform(-0.5, 0.5, (15, 3))])
    ao = np.repeat(starts, len(targets), axis=0)
    ad = np.tile(targets, (len(starts), 1)) - ao
    o, d = np.concatenate([o, ao]) + shift, np.concatenate([d, ad])
    return o, d


MESHES = {
    "icosphere": lambda: jittered_icosphere(),
    "box": lambda: subdivided_box(rotate=False),
    "tilted box": lambda: subdivided_box(rotate=True),
}


_BRUTE = {}


def brute_force(key, target, o, d):
    if key not in _BRUTE:
        _BRUTE[key] = cast_rays(target, o, d, accel="none")
    return _BRUTE[key]


# Translated by 1e5 too: the test subtracts the ray origin from each vertex
# first, and rounding there must not open the edges either.
@pytest.mark.parametrize("shift", [0.0, 1e5])
@pytest.mark.parametrize("mesh", list(MESHES))
@pytest.mark.parametrize("accel", STRUCTURES)
def test_rays_from_inside_never_miss(mesh, shift, accel):
    v, f = MESHES[mesh]()
    check_closed(f)
    v = v + shift
    o, d = inside_rays(v - shift, f, shift, seed=list(MESHES).index(mesh),
                       n_random=N_RAYS if shift == 0.0 else N_RAYS_SHIFTED)
    h = cast_rays((v, f), o, d, accel=accel)
    missed = np.flatnonzero(~h.hit)
    assert missed.size == 0, (f"{missed.size} of {len(o)} rays escaped, e.g. o={o[missed[0]].tolist()} "
                              f"d={d[missed[0]].tolist()}")
    # The hit is on the surface: for the sphere between the jittered radii,
    # for the box on a face (|coordinate| = 1 along some axis before tilting).
    p = o + h.t[:, None] * d - shift
    if mesh == "icosphere":
        r = np.linalg.norm(p, axis=1)
        assert r.min() > 0.9 and r.max() < 1.05 * (1 + 1e-9)
    elif mesh == "box":
        assert np.allclose(np.abs(p).max(axis=1), 1.0, atol=1e-9)
    assert occluded((v, f), o, d, np.inf, accel=accel).all()
    b = h if accel == "none" else brute_force((mesh, shift), (v, f), o, d)
    if accel == "none":
        _BRUTE[(mesh, shift)] = h
    else:   # bit-identical to brute force
        assert np.array_equal(h.t, b.t) and np.array_equal(h.prim_id, b.prim_id)
        assert np.array_equal(h.u, b.u) and np.array_equal(h.v, b.v)
