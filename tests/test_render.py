"""Whole renders: structures agree, counters are exact, options behave."""
import numpy as np
import pytest

from raytrace.errors import RaytraceError
from raytrace.renderer.driver import render
from tests.conftest import H, W
from tests.structures import EVERY_MODE

SHADOWS = ["none", "hard", "soft"]


ACCELS = ["bvol", "bvh", "grid"]
# Soft shadows with the default structure only (tests/structures.py).
CASES = [(shadows, accel) for shadows in SHADOWS for accel in ACCELS
         if shadows != "soft" or accel in EVERY_MODE]


@pytest.mark.parametrize("shadows, accel", CASES)
@pytest.mark.parametrize("scene", ["teapot_scene", "spheres_scene"])
def test_structures_match_brute_force(request, render_small, scene, shadows, accel):
    sc = request.getfixturevalue(scene)
    kw = dict(shadows=shadows, light_samples=16, aov=True)
    a = render_small(sc, accel="none", **kw)
    b = render_small(sc, accel=accel, **kw)
    assert np.array_equal(a.linear, b.linear)
    assert np.array_equal(a.image, b.image)
    assert np.array_equal(a.aovs["primid"], b.aovs["primid"])
    assert np.array_equal(a.aovs["depth"], b.aovs["depth"])
    ca, cb = a.stats["counters"], b.stats["counters"]
    for key in ("primary_rays", "shadow_rays", "shading_points", "occluded_rays"):
        assert ca[key] == cb[key], key
    assert cb["prim_tests"] < ca["prim_tests"]
    assert ca["box_tests"] == 0 and cb["box_tests"] > 0


def test_teapot_is_in_the_picture(render_small, teapot_scene):
    r = render_small(teapot_scene, accel="bvol", shadows="none", aov=True)
    prim = r.aovs["primid"]
    n_tris = r.stats["triangles"]
    on_teapot = (prim >= 0) & (prim < n_tris)
    # The teapot fills a good part of the frame, and the ground the rest.
    assert 0.15 < on_teapot.mean() < 0.6
    assert (prim == n_tris).sum() > 0.2 * prim.size


def test_primary_rays_exact_without_shadows(render_small, teapot_scene):
    c = render_small(teapot_scene, accel="bvol", shadows="none").stats["counters"]
    assert c["primary_rays"] == W * H
    assert c["shadow_rays"] == 0 and c["shadow_points"] == 0


@pytest.mark.parametrize("shadows, samples", [("hard", 1), ("soft", 16), ("soft", 81)])
def test_shadow_rays_are_points_times_samples(render_small, teapot_scene, shadows, samples):
    r = render_small(teapot_scene, accel="bvh", shadows=shadows, light_samples=samples)
    c = r.stats["counters"]
    assert c["shadow_points"] > 0
    assert c["shadow_rays"] == c["shadow_points"] * samples
    # Points facing away from the light cast no shadow rays at all.
    assert c["shadow_points"] < c["shading_points"]
    assert 0 < c["occluded_rays"] < c["shadow_rays"]


def test_spp_multiplies_primary_rays(render_small, spheres_scene):
    r = render_small(spheres_scene, accel="bvol", shadows="none", spp=4)
    assert r.stats["counters"]["primary_rays"] == 4 * W * H


def test_shadows_darken_without_changing_lit_pixels(render_small, teapot_scene):
    none = render_small(teapot_scene, accel="bvol", shadows="none").linear
    hard = render_small(teapot_scene, accel="bvol", shadows="hard").linear
    assert np.all(hard <= none)
    assert (hard < none).any(axis=2).mean() > 0.02   # a visible shadow
    assert (hard == none).all(axis=2).mean() > 0.5   # most pixels unchanged


def test_soft_shadow_has_penumbra(render_small, teapot_scene):
    none = render_small(teapot_scene, accel="bvh", shadows="none").linear
    hard = render_small(teapot_scene, accel="bvh", shadows="hard").linear
    soft = render_small(teapot_scene, accel="bvh", shadows="soft", light_samples=16).linear
    frac = lambda img: (img < none).any(axis=2) & (img > 0.02 + 0 * none).any(axis=2)  # noqa: E731
    # Partially lit pixels: darker than unshadowed, brighter than umbra.
    partial_soft = ((soft < none - 1e-6) & (soft > hard + 1e-6)).any(axis=2).sum()
    assert partial_soft > 20
    assert frac(soft).sum() >= frac(hard).sum()


def test_same_seed_same_image_across_threads(teapot_scene):
    kw = dict(accel="bvh", shadows="soft", light_samples=16, pattern="random", width=48, height=36, seed=7)
    a = render(teapot_scene, threads=1, **kw)
    b = render(teapot_scene, threads=2, **kw)
    assert np.array_equal(a.image, b.image)
    assert a.stats["counters"] == b.stats["counters"]
    c = render(teapot_scene, threads=2, **dict(kw, seed=8))
    assert not np.array_equal(a.linear, c.linear)


@pytest.mark.parametrize("kw, message", [
    (dict(width=0), "width"),
    (dict(height=-3), "height"),
    (dict(light_samples=-1), "light samples"),
    (dict(spp=0), "spp"),
    (dict(accel="octree"), "acceleration"),
    (dict(shadows="soft", light_samples=50), "square"),
    (dict(width=1 << 20, height=1 << 20), "GiB"),
])
def test_bad_options_raise_one_clear_error(teapot_scene, kw, message):
    with pytest.raises(RaytraceError, match=message):
        render(teapot_scene, **kw)


def test_spp_antialiases_edges():
    """A red disc on black, lit by its ambient term only: with one centred
    sample per pixel every pixel is exactly red or exactly black; jittered
    samples give silhouette pixels the fractions in between."""
    from raytrace.scene.model import Camera, Material, Scene, Sphere
    flat_red = Material(color=(1.0, 0.0, 0.0), ambient=1.0, diffuse=0.0, specular=0.0)
    scene = Scene("disc", Camera(eye=(0, 0, 5), look_at=(0, 0, 0), fov=40.0),
                  objects=[Sphere((0, 0, 0), 1.0, flat_red)], background=(0.0, 0.0, 0.0))
    kw = dict(accel="bvol", shadows="none", width=48, height=36)
    one = render(scene, spp=1, **kw).linear[..., 0]
    many = render(scene, spp=16, **kw).linear[..., 0]
    assert set(np.unique(one)) == {0.0, 1.0}
    edge = (many > 0) & (many < 1)
    assert edge.sum() > 20
    # Intermediate values sit on the silhouette, where spp=1 flips 0 -> 1.
    flips = np.zeros_like(one, dtype=bool)
    flips[:, 1:] |= one[:, 1:] != one[:, :-1]
    flips[:, :-1] |= one[:, 1:] != one[:, :-1]
    flips[1:] |= one[1:] != one[:-1]
    flips[:-1] |= one[1:] != one[:-1]
    assert flips[edge].all()
    assert np.array_equal(many[~flips], one[~flips])   # flat interior, flat background


def test_drop_meshes_frees_the_meshes_and_renders_the_same():
    """The command's render drops its scene's meshes once flattened (the
    build's peak then does not hold them too): same image and statistics,
    and the scene keeps only what is not a mesh."""
    from raytrace.scene.builtin import teapot
    from raytrace.scene.model import Mesh
    kept = render(teapot(4), accel="bvh", shadows="hard", width=W, height=H)
    scene = teapot(4)
    dropped = render(scene, accel="bvh", shadows="hard", width=W, height=H, drop_meshes=True)
    assert np.array_equal(kept.image, dropped.image)
    assert kept.stats["counters"] == dropped.stats["counters"]
    assert kept.stats["triangles"] == dropped.stats["triangles"] > 0
    assert scene.objects and not any(isinstance(o, Mesh) for o in scene.objects)


def test_progress_bands_give_the_same_image_and_counts(spheres_scene):
    """With a progress callback the image is rendered in bands of rows
    (several kernel calls): the same pixels and counters as in one call,
    and the callback sees every row done."""
    calls = []
    banded = render(spheres_scene, width=40, height=300,
                    progress=lambda done, total: calls.append((done, total)))
    whole = render(spheres_scene, width=40, height=300)
    assert np.array_equal(banded.linear, whole.linear)
    assert banded.stats["counters"] == whole.stats["counters"]
    assert len(calls) > 1 and calls[-1] == (300, 300)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_bands_of_mirrors_and_paths_give_the_same_image_and_counts(integrator):
    """A render's threads keep their stages, buffers and packed records from
    band to band (kernels/waves.py render_rows): mirror and glass
    generations, whose buffers grow, and paths, whose generations take
    turns, give the pixels and counters of one call."""
    from pathlib import Path

    from raytrace import load_scene
    scene = load_scene(str(Path(__file__).resolve().parent.parent / "assets" / "whitted.toml"))
    kw = dict(width=48, height=200, integrator=integrator, spp=2)
    calls = []
    banded = render(scene, progress=lambda done, total: calls.append(done), **kw)
    whole = render(scene, **kw)
    assert np.array_equal(banded.linear, whole.linear)
    assert banded.stats["counters"] == whole.stats["counters"]
    assert len(calls) > 1


@pytest.mark.parametrize("specular, shininess", [(0.5, 20.0), (0.0, 1.0), (0.0, 48.0)])
def test_blinn_phong_at_a_known_point(specular, shininess):
    """The centre pixel of a 3x3 render looks straight down -z at the top
    of a unit sphere, (0, 0, 1), normal +z: its colour is the ambient term
    plus the light's diffuse and specular terms, as written out here.  The
    specular-free materials check the shortcut that leaves out the half
    vector and pow where the specular share is 0."""
    import math

    from raytrace.scene.model import Camera, Light, Material, Scene, Sphere
    c, ka, kd = (0.7, 0.5, 0.3), 0.1, 0.8
    mat = Material(color=c, ambient=ka, diffuse=kd, specular=specular, shininess=shininess)
    scene = Scene("ball", Camera(eye=(0, 0, 5), look_at=(0, 0, 0), fov=40.0),
                  objects=[Sphere((0, 0, 0), 1.0, mat)], lights=[Light(position=(2, 3, 4))],
                  background=(0.0, 0.0, 0.0))
    got = render(scene, accel="bvol", shadows="none", width=3, height=3).linear[1, 1]
    lx, ly, lz = 2.0, 3.0, 3.0
    dist = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / dist, ly / dist, lz / dist
    hx, hy, hz = lx, ly, lz + 1.0
    spec = specular * max(0.0, hz / math.sqrt(hx * hx + hy * hy + hz * hz)) ** shininess
    want = [ka * ci + kd * ci * lz + spec for ci in c]
    assert np.allclose(got, want, rtol=2.0 ** -23, atol=0.0)    # .linear is float32


@pytest.mark.parametrize("n, side", [(9, 3), (16, 4)])
def test_a_grid_lights_shadow_rays_go_to_its_cell_centres_in_order(n, side):
    """Soft shadows with the grid pattern: sample s of a side-by-side grid
    aims at the centre of cell (s % side, s // side) of the light (the
    emitting loop counts the cell along rather than dividing)."""
    from collections import namedtuple

    from raytrace.kernels.jit import python_callable
    from raytrace.kernels.sampling import PATTERN_GRID
    from raytrace.kernels.wavefront import _emit_shadow_rays, shadow_buffers
    from raytrace.renderer.driver import light_buffers
    from raytrace.scene.model import Camera, Light, Scene
    scene = Scene("light", Camera(eye=(0, 0, 5), look_at=(0, 0, 0)),
                  lights=[Light(position=(1.0, 4.0, -2.0), size=2.0, samples=n)])
    lights = light_buffers(scene, "soft", n)
    shading = namedtuple("Shading", ["shadow_mode", "lights", "seed"])(PATTERN_GRID, lights, 0)
    rays = shadow_buffers(n + 2, 1)
    emit = python_callable(_emit_shadow_rays)
    assert emit(shading, 0, (0.0, 0.0, 0.0), 7, 0, rays, 1) == n
    for s in range(n):
        su, sv = (s % side + 0.5) / side, (s // side + 0.5) / side
        aim = lights.pos[0] + (su - 0.5) * lights.u[0] + (sv - 0.5) * lights.v[0]
        assert np.array_equal(rays.dirs[1 + s], aim), s      # from the origin (0, 0, 0)


def test_a_lights_sample_hashes_are_rand01s_own():
    """Soft shadows look up rand01's hash of (sample, dimension) in the
    Lights record (sampling.sample_hashes, made in NumPy) instead of making
    it per pixel: the same numbers, bit for bit, as rand01 makes."""
    from raytrace.kernels.jit import python_callable
    from raytrace.kernels.sampling import rand01, rand01_hashed, sample_hashes
    whole, looked_up = python_callable(rand01), python_callable(rand01_hashed)
    hashes = sample_hashes(300)
    assert hashes.dtype == np.uint64 and hashes.shape == (600,)
    rng = np.random.default_rng(5)
    for key in rng.integers(0, 2**63, 8, dtype=np.uint64):
        for s in (0, 1, 17, 80, 299):
            for dim in (0, 1):
                assert looked_up(key, hashes[2 * s + dim]) == whole(key, s, dim)


@pytest.mark.parametrize("rows", [1, 7, 480, 1001])
def test_srgb_encoding_is_the_same_on_any_number_of_threads(rows):
    """to_srgb8 spreads its bands over threads: every pixel is encoded once,
    with the same arithmetic as the whole image at once."""
    from raytrace.renderer.driver import to_srgb8
    rng = np.random.default_rng(rows)
    linear = (rng.random((rows, 333, 3), dtype=np.float32) * 1.4 - 0.2).astype(np.float32)
    linear[0, :4, 0] = [0.0031308, 0.0031309, 0.0, 1.0]
    c = np.clip(linear, 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    whole = (s * 255.0 + 0.5).astype(np.uint8)
    for threads in (1, 2, 3):
        assert np.array_equal(to_srgb8(linear, threads), whole)
