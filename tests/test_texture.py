"""The checkerboard: box-filtered over each camera sample's footprint by
default, point-sampled with texture_filter="none" (issue 17)."""
import sys
from pathlib import Path

import numpy as np
import pytest

from raytrace.kernels.jit import python_callable
from raytrace.kernels.shade import DARK_SQUARE, checker_box
from raytrace.renderer.driver import render
from raytrace.scene.model import Camera, Material, Plane, Scene
from tests.conftest import H, W

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))

import terminator_checker  # noqa: E402

# Per-ray kernel functions are compiled without Python wrappers (kernels/jit.py).
checker_box = python_callable(checker_box)


def brute_checker_box(u, v, hu, hv, n=2000):
    """The box's odd fraction by the midpoint rule on an n x n grid."""
    su = u - hu + (np.arange(n) + 0.5) * (2 * hu / n)
    sv = v - hv + (np.arange(n) + 0.5) * (2 * hv / n)
    odd = (np.floor(su)[:, None] + np.floor(sv)[None, :]) % 2
    return odd.mean()


@pytest.mark.parametrize("u, v, hu, hv, want", [
    (0.5, 0.5, 0.25, 0.25, 0.0),     # inside the even square [0,1)^2
    (1.5, 0.5, 0.25, 0.25, 1.0),     # inside an odd one
    (1.0, 0.5, 0.5, 0.25, 0.5),      # straddles the edge u = 1 evenly
    (1.0, 1.0, 0.5, 0.5, 0.5),       # centred on a corner: two odd quarters
    (0.3, 7.9, 1.0, 0.0, 0.5),       # a whole period in u: half odd whatever v
    (-0.5, 0.5, 0.25, 0.25, 1.0),    # negative u: floor -1 is odd
    (0.5, 0.5, np.inf, 0.1, 0.5),    # unbounded footprint: the mean
    (1.5, 2.5, 0.0, 0.0, 1.0),       # zero footprint: the point sample
])
def test_checker_box_hand_computed(u, v, hu, hv, want):
    assert checker_box(u, v, hu, hv) == pytest.approx(want, abs=1e-12)


def test_checker_box_matches_brute_force_integral():
    rng = np.random.default_rng(17)
    for _ in range(40):
        u, v = rng.uniform(-20, 20, 2)
        hu, hv = rng.uniform(0.01, 3.0, 2)
        assert checker_box(u, v, hu, hv) == pytest.approx(brute_checker_box(u, v, hu, hv), abs=2e-3)


def flat_checker_scene():
    """A checkered plane lit by its ambient term only, so a pixel shows the
    albedo itself, seen at a grazing angle out to the horizon."""
    ground = Material(color=(0.8, 0.6, 0.4), ambient=1.0, diffuse=0.0, specular=0.0, checker=1.0)
    return Scene("flat", Camera(eye=(0.3, 1.5, 0.2), look_at=(6.0, 0.0, -20.0), fov=60.0),
                 objects=[Plane((0, 0, 0), (0, 1, 0), ground)], background=(0.0, 0.0, 0.0))


def test_filtered_far_ground_is_the_mean_of_the_two_colours():
    """Far away a pixel covers many squares: the filtered checker shows the
    mean of its colours there, the raw one one colour or the other."""
    scene = flat_checker_scene()
    kw = dict(accel="bvh", shadows="none", width=W, height=H, aov=True)
    box = render(scene, **kw)
    raw = render(scene, texture_filter="none", **kw)
    color = np.array(scene.objects[0].material.color)
    mean = color * (1 + DARK_SQUARE) / 2
    # Beyond 20 squares away a pixel spans several squares at this size.
    far = terminator_checker._interior(box.aovs["primid"] == 0) & (box.aovs["depth"] > 20)
    assert far.sum() > 300
    dev_box = np.abs(box.linear[far] - mean) / color
    dev_raw = np.abs(raw.linear[far] - mean) / color
    # 3 % of the colour: the box is a footprint's bounding box in (u, v),
    # so a pixel's average is of a few squares, not an infinite number.
    assert dev_box.mean() < 0.01 and dev_box.max() < 0.03
    # The raw checker is one colour or the other: (1 - 0.35) / 2 away.
    assert dev_raw.min() == pytest.approx((1 - DARK_SQUARE) / 2)


def test_filtered_near_ground_keeps_its_squares():
    """Near the camera a square spans many pixels: filtering only softens
    the pixels on the squares' edges."""
    scene = flat_checker_scene()
    kw = dict(accel="bvh", shadows="none", width=W, height=H, aov=True)
    box = render(scene, **kw)
    raw = render(scene, texture_filter="none", **kw)
    near = (box.aovs["primid"] == 0) & (box.aovs["depth"] < 3)
    assert near.sum() > 250
    same = np.all(box.linear[near] == raw.linear[near], axis=1)
    assert same.mean() > 0.8


@pytest.mark.parametrize("accel", ["bvol", "bvh", "grid"])
def test_texture_filter_changes_no_counter_and_no_structure_agrees(render_small, teapot_scene, accel):
    kw = dict(shadows="hard", aov=True)
    box = render_small(teapot_scene, accel=accel, **kw)
    raw = render_small(teapot_scene, accel=accel, texture_filter="none", **kw)
    brute = render_small(teapot_scene, accel="none", texture_filter="none", **kw)
    assert box.stats["counters"] == raw.stats["counters"]
    assert np.array_equal(raw.image, brute.image)
    assert not np.array_equal(box.image, raw.image)


def test_spp_shrinks_the_footprint(render_small, teapot_scene):
    """With more samples each filters a smaller share of the pixel: the
    average stays the pixel's, and converges to the raw checker's."""
    kw = dict(accel="bvh", shadows="none", spp=16)
    box = render_small(teapot_scene, **kw).linear
    raw = render_small(teapot_scene, texture_filter="none", **kw).linear
    one = render_small(teapot_scene, accel="bvh", shadows="none").linear
    assert np.abs(box - raw).mean() < np.abs(one - raw).mean()


def test_far_ground_rmse_against_the_supersampled_raw_checker():
    """The bench's measure at a small size: 1 spp filtered is far closer to
    64 spp of the raw checker over the far half of the ground than 1 spp raw."""
    w, h = 160, 120
    raw, _, _, ref = terminator_checker.checker_error(w, h, "none", reference_spp=64)
    box, _, _, _ = terminator_checker.checker_error(w, h, "box", reference=ref)
    assert box < 0.4 * raw
