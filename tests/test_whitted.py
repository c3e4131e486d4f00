"""Mirrors and glass (Whitted 1980): directions and Fresnel weights against
textbook answers, exact ray counts where the geometry fixes them, offsets
that hold at every scale, and every structure giving the same image."""
import math

import numpy as np
import pytest
from click.testing import CliRunner

from raytrace.cli.main import main
from raytrace.kernels.jit import python_callable
from raytrace.kernels.optics import bounce_weights, reflect, refract, schlick
from raytrace.renderer.driver import render
from raytrace.scene.assets import assets_dir
from raytrace.scene.load import load_scene
from raytrace.scene.model import Camera, Light, Material, Plane, Scene, Sphere
from tests.scene_transform import transform_scene
from tests.structures import EVERY_MODE

# Per-ray kernel functions are compiled without Python wrappers (kernels/jit.py).
bounce_weights, reflect, refract, schlick = map(python_callable, (bounce_weights, reflect, refract, schlick))

CASES = [(scale, shift) for shift in (0.0, 1e5) for scale in (1e-4, 1.0, 1e4)]
SMALL = dict(width=32, height=24)


def whitted_file():
    return assets_dir() / "whitted.toml"


def unit(*v):
    v = np.array(v, float)
    return v / np.linalg.norm(v)


def test_a_mirror_at_45_degrees_turns_a_ray_by_90():
    n = unit(-1, 1, 0)
    assert reflect(1.0, 0.0, 0.0, *n) == pytest.approx((0.0, 1.0, 0.0), abs=1e-15)


def test_a_glass_slab_shifts_a_ray_sideways_by_the_textbook_amount():
    """In through the top face, out through the bottom: the ray leaves
    parallel to itself, displaced by t sin(i - r) / cos(r) (Hecht, Optics,
    4.4) for a slab of thickness t."""
    ior, thick, i = 1.5, 0.2, math.radians(40)
    d = np.array([math.sin(i), -math.cos(i), 0.0])
    ok, *t_in = refract(*d, 0.0, 1.0, 0.0, 1.0 / ior)
    assert ok
    t_in = np.array(t_in)
    r = math.asin(math.sin(i) / ior)
    assert math.atan2(t_in[0], -t_in[1]) == pytest.approx(r)
    ok, *out = refract(*t_in, 0.0, 1.0, 0.0, ior)      # bottom face, normal towards the ray
    assert ok and np.allclose(out, d, atol=1e-15)
    # Entry at the origin; the exit point and the unbent line's offset.
    exit_ = t_in * (thick / -t_in[1])
    offset = np.linalg.norm(np.cross(exit_, d))
    assert offset == pytest.approx(thick * math.sin(i - r) / math.cos(r))


def test_total_internal_reflection_past_the_critical_angle():
    ior = 1.5
    critical = math.asin(1.0 / ior)
    for angle, expect_ok in ((critical - 1e-6, True), (critical + 1e-6, False)):
        d = (math.sin(angle), -math.cos(angle), 0.0)
        ok, *_ = refract(*d, 0.0, 1.0, 0.0, ior)          # leaving glass into air
        assert ok is expect_ok
    assert schlick(math.cos(critical + 1e-6), ior) == 1.0
    assert schlick(1.0, 1.0 / ior) == pytest.approx(0.04)  # ((1.5 - 1) / (1.5 + 1))^2
    assert schlick(0.0, 1.0 / ior) == pytest.approx(1.0)   # grazing: all reflected


@pytest.mark.parametrize("eta", [1 / 1.5, 1.5, 1 / 2.42, 1.0])
def test_the_weights_share_out_the_light_exactly(eta):
    for kr in np.linspace(0, 1, 6):
        for kt in np.linspace(0, 1 - kr, 5):
            for c in np.linspace(0, 1, 7):
                own, refl, refr = bounce_weights(kr, kt, c, eta)
                assert min(own, refl, refr) >= -1e-15
                assert own + refl + refr == pytest.approx(1.0, abs=1e-15)


def test_no_secondary_rays_and_no_bounce_kernel_without_mirrors(render_small, teapot_scene):
    r = render_small(teapot_scene, accel="bvh", shadows="hard")
    assert r.stats["counters"]["reflection_rays"] == r.stats["counters"]["refraction_rays"] == 0
    assert r.stats["max_depth"] is None


MIRROR = Material(color=(1.0, 1.0, 1.0), ambient=0.0, diffuse=0.0, specular=0.0, reflect=1.0)


def facing_mirrors():
    """Two infinite mirrors, z = -1 and z = 1, the camera between them
    looking at one: every ray bounces between them for ever."""
    return Scene("mirrors", Camera((0, 0, 0), (0.3, 0.1, -1.0), fov=50.0),
                 [Plane((0, 0, -1), (0, 0, 1), MIRROR), Plane((0, 0, 1), (0, 0, -1), MIRROR)],
                 lights=[Light((0, 0.5, 0))])


@pytest.mark.parametrize("max_depth", [0, 1, 3, 16])
def test_recursion_stops_at_max_depth(max_depth):
    r = render(facing_mirrors(), max_depth=max_depth, **SMALL)
    c = r.stats["counters"]
    n = 32 * 24
    assert c["shading_points"] == n
    assert c["reflection_rays"] == n * max_depth and c["refraction_rays"] == 0
    assert c["depth_limited_rays"] == n              # each pixel's last mirror ray
    assert c["shadow_rays"] == 0                     # a perfect mirror has no shading of its own
    assert r.stats["max_depth"] == max_depth


GLASS = Material(color=(1.0, 1.0, 1.0), ambient=0.0, diffuse=0.0, specular=0.0, transmit=1.0,
                 ior=1.5)


@pytest.mark.parametrize("scale, shift", CASES)
def test_camera_inside_a_glass_sphere(scale, shift):
    """From the centre every ray meets the sphere head on, from inside: it
    refracts straight out (to the sky) and reflects back through the centre
    to the far side, which does the same; at max depth 2 that is two
    refracted and two reflected rays per pixel, exactly, unless a ray
    re-hits the surface it leaves (offsets on the wrong side or too short)."""
    scene = Scene("inside", Camera((0, 0, 0), (0.2, 0.1, -1.0), fov=60.0),
                  [Sphere((0, 0, 0), 1.0, GLASS)], lights=[Light((0, 0, 0.5))])
    r = render(transform_scene(scene, scale, shift), max_depth=2, **SMALL)
    c = r.stats["counters"]
    n = 32 * 24
    assert (c["shading_points"], c["refraction_rays"], c["reflection_rays"]) == (n, 2 * n, 2 * n)
    # The second reflection's hit, at depth 2, would refract and reflect.
    assert c["depth_limited_rays"] == 2 * n
    assert c["prim_hits"] == 3 * n                   # the camera ray's hit and two reflections'
    assert np.isfinite(r.linear).all() and (r.linear > 0).all()


@pytest.mark.parametrize("scale, shift", CASES)
def test_a_convex_mirror_sends_every_ray_away(scale, shift):
    """Rays reflected off a lone mirror sphere leave it: one reflection per
    camera hit and no further hit, at every scale and far from the origin."""
    scene = Scene("ball", Camera((0.2, 0.5, 4.0), (0, 0, 0), fov=32.0),
                  [Sphere((0, 0, 0), 1.0, MIRROR)], lights=[Light((2, 3, 4))])
    c = render(transform_scene(scene, scale, shift), **SMALL).stats["counters"]
    assert c["shading_points"] > 0.3 * 32 * 24
    assert c["reflection_rays"] == c["shading_points"] == c["prim_hits"]


def test_the_default_structure_renders_mirrors_and_glass_as_brute_force_does():
    # The other structures' hits on such rays: tests/structures.py.
    scene = load_scene(whitted_file(), **SMALL)
    first = None
    for accel in EVERY_MODE:
        r = render(scene, accel=accel)
        c = r.stats["counters"]
        assert c["reflection_rays"] > 0 and c["refraction_rays"] > 0
        if first is None:
            first = r
            continue
        assert np.array_equal(r.linear, first.linear), accel
        assert {k: c[k] for k in ("reflection_rays", "refraction_rays", "shadow_rays")} == \
            {k: first.stats["counters"][k] for k in ("reflection_rays", "refraction_rays",
                                                      "shadow_rays")}


@pytest.mark.parametrize("key, value, message", [
    ("reflect", 1.5, "materials.m.reflect: "),
    ("transmit", -0.1, "materials.m.transmit: "),
    ("ior", 0.5, "materials.m.ior: "),
    ("transmit", 0.6, "reflect + transmit must be at most 1"),
])
def test_bad_mirror_and_glass_keys(tmp_path, key, value, message):
    f = tmp_path / "s.toml"
    material = {"reflect": 0.5, key: value}
    f.write_text("[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n[materials.m]\n"
                 + "".join(f"{k} = {v}\n" for k, v in material.items())
                 + '[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = "m"\n')
    r = CliRunner().invoke(main, [str(f), "-o", str(tmp_path / "s.png")])
    assert r.exit_code == 1 and message in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "s.png").exists()


def test_a_samples_light_is_summed_in_depth_first_order():
    """The wavefront makes a sample's rays generation by generation, but
    sums their light in the order a depth-first tracer adds it (a ray, then
    its reflected subtree, then its refracted one): bounces.gather sorts by
    each ray's key.  The values are chosen so that the order changes the
    float sum: the breadth-first order gives 5.5 where depth first gives
    4.5."""
    from raytrace.kernels.bounces import DIGIT, gather, light_buffers
    from raytrace.kernels.wavefront import wave_buffers
    d1, d2 = int(DIGIT[1]), int(DIGIT[2])
    key = {"root": 0, "R": d1, "RR": d1 + d2, "RT": d1 + 2 * d2, "T": 2 * d1, "TR": 2 * d1 + d2}
    value = {"root": 1e16, "R": 1.0, "RR": -1e16, "RT": 1.0, "T": 3.0, "TR": 0.5}
    depth_first = ["root", "R", "RR", "RT", "T", "TR"]
    breadth_first = ["root", "R", "T", "RR", "RT", "TR"]

    def summed(order):
        total = 0.0
        for name in order:
            total += value[name]
        return total
    assert summed(depth_first) == 4.5 and summed(breadth_first) == 5.5
    # Two samples' contributions interleaved, in generation order.
    rows = [(k, name) for name in breadth_first for k in (0, 1)]
    light = light_buffers(len(rows), 2)
    for j, (k, name) in enumerate(rows):
        light.sample[j], light.key[j] = k, key[name]
        light.rgb[j] = (value[name] * (k + 1), value[name], 0.0)
    wave = wave_buffers(2)
    python_callable(gather)(wave, 2, light, len(rows))
    assert wave.rgb[0].tolist() == [4.5, 4.5, 0.0]
    assert wave.rgb[1].tolist() == [9.0, 4.5, 0.0]
