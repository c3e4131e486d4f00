"""The workload suite's ray sets (bench/workload.py) are what they claim,
on a unit square seen from above: no peers, no kernels."""
import sys
from pathlib import Path

import numpy as np
import pytest

from raytrace.scene.model import Camera, Light

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))

import workload  # noqa: E402

# The square [0, 1]^2 at z = 0 as two triangles, split along its diagonal.
V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float64)
F = np.array([[0, 1, 2], [0, 2, 3]], np.int64)
CAMERA = Camera(eye=(0.5, 0.5, 2.0), look_at=(0.5, 0.5, 0.0), up=(0, 1, 0), fov=60.0)
LIGHT = Light(position=(0.5, 0.5, 3.0), size=2.0, direction=(0, 0, -1))


def square_hits(o, d):
    """(prim, t) of rays against the square, by hand: the plane z = 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[:, 2] / d[:, 2]
    p = o + t[:, None] * d
    inside = (t > 0) & np.all((p[:, :2] >= 0) & (p[:, :2] <= 1), axis=1)
    prim = np.where(inside, np.where(p[:, 0] >= p[:, 1], 0, 1), -1)
    return prim, np.where(inside, t, np.inf)


def test_camera_rays_are_pixel_centres_in_image_order():
    o, d = workload.camera_rays(CAMERA, 5, 3)
    assert o.shape == d.shape == (15, 3) and o.dtype == d.dtype == np.float64
    assert np.all(o == [0.5, 0.5, 2.0])
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    np.testing.assert_allclose(d[7], [0, 0, -1], atol=1e-15)   # the middle pixel looks ahead
    img = d.reshape(3, 5, 3)
    assert np.all(np.diff(img[:, :, 0], axis=1) > 0)           # left to right along a row
    assert np.all(np.diff(img[:, :, 1], axis=0) < 0)           # rows from the top down


def test_shuffled_is_a_permutation_of_the_same_rays():
    o, d = workload.camera_rays(CAMERA, 8, 6)
    so, sd, perm = workload.shuffled((o, d), np.random.default_rng(1))
    assert np.array_equal(np.sort(perm), np.arange(len(o)))
    assert not np.array_equal(perm, np.arange(len(o)))
    assert np.array_equal(so, o[perm]) and np.array_equal(sd, d[perm])
    again = workload.shuffled((o, d), np.random.default_rng(1))[2]
    assert np.array_equal(perm, again)                          # the seed fixes the order


def test_box_rays_start_on_a_sphere_and_pass_through_the_box():
    lo, hi = np.array([-1.0, 0, 2]), np.array([3.0, 1, 2.5])
    o, d = workload.box_rays(lo, hi, 5000, np.random.default_rng(2))
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    np.testing.assert_allclose(np.linalg.norm(o - centre, axis=1), radius)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    with np.errstate(divide="ignore"):                          # slab test
        a, b = (lo - o) / d, (hi - o) / d
    near = np.max(np.minimum(a, b), axis=1)
    far = np.min(np.maximum(a, b), axis=1)
    assert np.all((near <= far) & (near > 0))                   # enters the box, from outside
    # Origins all round the sphere, not on one side.
    assert np.all(np.abs(np.mean((o - centre) / radius, axis=0)) < 0.05)


def test_surface_points_and_normals_face_the_ray():
    o = np.array([[0.7, 0.2, 1.0], [0.2, 0.7, 1.0], [2.0, 2.0, 1.0], [0.5, 0.4, -1.0]])
    d = np.array([[0, 0, -1.0], [0, 0, -1.0], [0, 0, -1.0], [0, 0, 1.0]])
    prim, t = square_hits(o, d)
    assert list(prim) == [0, 1, -1, 0]
    p, n = workload.surface(V, F, o, d, prim, t)
    np.testing.assert_allclose(p, [[0.7, 0.2, 0], [0.2, 0.7, 0], [0.5, 0.4, 0]])
    np.testing.assert_allclose(n, [[0, 0, 1], [0, 0, 1], [0, 0, -1]])   # towards each origin


def test_shadow_rays_end_at_their_targets_from_the_lit_side_only():
    p = np.array([[0.2, 0.3, 0.0], [0.6, 0.6, 0.0]])
    n = np.array([[0, 0, 1.0], [0, 0, -1.0]])                  # the second faces away
    o, d, lit = workload.shadow_rays(p, n, LIGHT.position)
    assert list(lit) == [True, False]
    np.testing.assert_allclose(o + d, [LIGHT.position])         # the light at t = 1
    np.testing.assert_allclose(o, p[:1] + workload.OFFSET * n[:1])
    targets = np.array([[0, 0, 5.0], [1, 1, 5.0]])
    o, d, lit = workload.shadow_rays(p, -n, targets)            # one target per point
    np.testing.assert_allclose(o + d, targets[1:])


def test_area_light_points_cover_the_lights_square():
    q = workload.area_light_points(LIGHT, 4000, np.random.default_rng(3))
    off = q - LIGHT.position
    np.testing.assert_allclose(off[:, 2], 0.0, atol=1e-12)     # in the plane facing down
    assert np.all(np.abs(off[:, :2]) <= 1.0 + 1e-12)
    assert np.all(np.max(np.abs(off[:, :2]), axis=0) > 0.95)   # reaching its edges


def test_cosine_rays_lie_in_the_hemisphere_with_cosine_density():
    n_rays = 40_000
    rng = np.random.default_rng(4)
    normals = rng.normal(size=(n_rays, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = rng.uniform(size=(n_rays, 3))
    o, d = workload.cosine_rays(points, normals, rng)
    np.testing.assert_allclose(o, points + workload.OFFSET * normals)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    cos = np.sum(d * normals, axis=1)
    assert np.all(cos > 0)
    # E[cos] = 2/3 under p ~ cos (1/2 for uniform directions); E[cos^2] = 1/2.
    assert abs(cos.mean() - 2 / 3) < 0.01 and abs(np.mean(cos ** 2) - 0.5) < 0.01
    # No preferred azimuth: the part across the normal averages out.
    assert np.linalg.norm(np.mean(d - cos[:, None] * normals, axis=0)) < 0.01


def test_ray_sets_have_every_set_and_the_float32_copies():
    sets = workload.ray_sets(V, F, CAMERA, LIGHT, square_hits, width=16, height=12, seed=5)
    assert set(sets) == {name for name, _ in workload.ROWS}
    for name, (o, d, _) in sets.items():
        assert o.shape == d.shape and o.shape[1] == 3, name
        assert o.dtype == d.dtype == (np.float32 if name.endswith("f32") else np.float64), name
    cam_o, cam_d, _ = sets["camera"]
    assert len(cam_o) == 16 * 12
    assert np.array_equal(sets["camera f32"][1], cam_d.astype(np.float32))
    assert np.array_equal(sets["box f32"][0], sets["box"][0].astype(np.float32))
    hits = (square_hits(cam_o, cam_d)[0] >= 0).sum()
    assert 0 < hits < len(cam_o)
    assert len(sets["bounce"][0]) == hits                      # one bounce per hit
    for name in ("shadow-point", "shadow-area"):                # every hit sees the light here
        o, d, tm = sets[name]
        assert len(o) == hits and tm == 1.0
    np.testing.assert_allclose(sets["shadow-point"][0] + sets["shadow-point"][1],
                               np.broadcast_to(LIGHT.position, (hits, 3)))
    assert sorted(map(tuple, sets["shuffled"][1])) == sorted(map(tuple, cam_d))


@pytest.mark.parametrize("bad", [0, 1])
def test_agreement_counts_equal_answers(bad):
    a = np.array([3, -1, 2, 2])
    b = a.copy()
    b[:bad] += 1
    assert workload._agree("closest", a, b) == (4 - bad) / 4
