"""The path tracer (--integrator path, kernels/pathtrace.py): unbiased
(the furnace), its techniques agreeing, its direct light the whitted
image's diffuse term, and the same bits for any tile split, thread count
and structure.  Tiny images: the suite's time is spent."""
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

import raytrace
from raytrace.cli.main import main
from raytrace.errors import RaytraceError
from raytrace.kernels.pathtrace import BSDF_ONLY, LIGHTS_ONLY, MIS
from raytrace.renderer.driver import RenderOptions, camera_buffer, prepare, render_band
from raytrace.renderer.emitters import path_record
from raytrace.scene.model import Camera, Light, Material, Mesh, Plane, Scene, Sphere

# Standard errors a mean may differ from what it estimates by: a false
# alarm about once in 16,000 runs for a normal mean.
SIGMAS = 4.0


def ball(levels=3):
    """A unit sphere of 8 x 4^levels flat triangles (an octahedron
    subdivided, its vertices pushed onto the sphere), wound outwards."""
    v = [np.array(p, float) for p in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1),
                                      (0, 0, -1))]
    f = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    mid = {}        # an edge's midpoint (a level's edges are all new)

    def m(a, b):
        if (min(a, b), max(a, b)) not in mid:
            p = v[a] + v[b]
            v.append(p / np.linalg.norm(p))
            mid[min(a, b), max(a, b)] = len(v) - 1
        return mid[min(a, b), max(a, b)]
    for _ in range(levels):
        f = [t for a, b, c in f for t in ((a, m(a, b), m(c, a)), (b, m(b, c), m(a, b)),
                                          (c, m(c, a), m(b, c)), (m(a, b), m(b, c), m(c, a)))]
    return np.array(v), np.array(f)


def render_paths(scene, size, spp, **paths):
    """The linear image of a path-traced render with Paths fields changed
    (strategy, roulette_depth): the driver's own stages."""
    opts = RenderOptions(width=size, height=size, spp=spp, integrator="path", threads=2,
                         max_depth=paths.pop("max_depth", 5))
    setup = prepare(scene, opts)
    record = path_record(setup.geo, opts.max_depth, **paths)
    payload = setup.payload()._replace(bounces=record)
    image, _, _, _ = render_band(payload, camera_buffer(scene.camera, size, size), 0, size, 2)
    return image.astype(np.float64)


def furnace(a, e):
    """Inside a ball of flat triangles wound inwards (so its emission
    faces in) of albedo a and emission e, looking about."""
    v, f = ball()
    return Scene("furnace", Camera(eye=(0.1, -0.05, 0.0), look_at=(0.3, 0.1, 1.0), fov=100.0),
                 objects=[Mesh(v * 3.0, f[:, ::-1].copy(), Material(
                     color=(a, a, a), ambient=0.0, diffuse=1.0, specular=0.0,
                     emission=(e, e, e)), name="inside")],
                 background=(0.0, 0.0, 0.0))


@pytest.fixture(scope="module", autouse=True)
def path_stage_compiled_once(tmp_path_factory):
    """Two workers of `pytest -n` reaching these tests at once would each
    compile the path stage (9 s): neither finds it cached yet.  The first
    to take this lock (a file in the workers' shared temporary directory)
    compiles it; the other then loads it from the kernel cache."""
    import fcntl
    with open(tmp_path_factory.getbasetemp().parent / "path_stage.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            render_paths(furnace(0.5, 0.7), 2, 1)
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def test_furnace_closed_sphere_is_e_over_one_minus_albedo():
    """Inside a closed surface of albedo a emitting E everywhere, every
    path meets surfaces only, so every pixel's expectation is E (1 + a +
    ... + a^D) for D bounces, E / (1 - a) as D grows (the furnace test).
    Without roulette the estimate per sample is bounded, and the pixels
    are independent estimates of that one value: their mean must be within
    SIGMAS standard errors (their own spread / sqrt(pixels)) of it, and
    every pixel within SIGMAS x sqrt(2 log pixels) of their spread (the
    largest of n normal deviates stays below sqrt(2 log n) sigmas)."""
    a, e, depth = 0.5, 0.7, 16
    scene = furnace(a, e)
    expected = e * (1.0 - a ** (depth + 1)) / (1.0 - a)
    img = render_paths(scene, 12, 8, max_depth=depth, roulette_depth=depth + 1)[..., 0]
    n = img.size
    s = img.std(ddof=1)
    assert abs(img.mean() - expected) <= SIGMAS * s / np.sqrt(n) + 1e-12, (img.mean(), expected)
    assert np.abs(img - expected).max() <= SIGMAS * np.sqrt(2 * np.log(n)) * s + 1e-12
    # Russian roulette (the default from bounce 3) keeps the mean: E / (1 - a)
    # less what 16 bounces cut, within its own, larger, noise.
    rr = render_paths(scene, 12, 8, max_depth=depth)[..., 0]
    assert abs(rr.mean() - expected) <= SIGMAS * rr.std(ddof=1) / np.sqrt(n)
    # Emission leaves a triangle's front only: wound outwards, the ball is dark inside.
    scene.objects[0].faces = scene.objects[0].faces[:, ::-1].copy()
    assert render_paths(scene, 4, 1, max_depth=depth).max() == 0.0


def cornell(size):
    scene = raytrace.load_scene("cornell", width=size, height=size)
    return scene


def glossy_cornell(size):
    """The Cornell box with its white surfaces half glossy (exponent 20)."""
    import dataclasses
    scene = cornell(size)
    for o in scene.objects:
        if o.material.color == (0.725, 0.71, 0.68):
            o.material = dataclasses.replace(o.material, diffuse=0.5, glossy=0.5, shininess=20.0)
    return scene


@pytest.mark.parametrize("name", ["cornell", "furnace", "glossy"])
def test_mis_and_each_technique_alone_agree_in_the_mean(name):
    """Light samples alone, bounce rays alone and the two weighted by MIS
    estimate the same image: per pixel their differences average 0,
    within SIGMAS standard errors of those differences.  A weight that
    does not sum to one over the two techniques, or a light sample's
    density off by a factor, moves MIS's mean away from the others (in
    the furnace, where bounce rays meet the emitter everywhere, by many
    standard errors; the Cornell box's small light leaves MIS nearly all
    to light samples)."""
    scene = {"cornell": lambda: cornell(16), "furnace": lambda: furnace(0.5, 0.7),
             "glossy": lambda: glossy_cornell(16)}[name]()
    images = {s: render_paths(scene, 16, 16, strategy=s, max_depth=3)
              for s in (MIS, BSDF_ONLY, LIGHTS_ONLY)}
    for a, b in ((MIS, BSDF_ONLY), (MIS, LIGHTS_ONLY), (LIGHTS_ONLY, BSDF_ONLY)):
        d = (images[a] - images[b]).reshape(-1, 3)
        se = d.std(axis=0, ddof=1) / np.sqrt(len(d))
        assert (np.abs(d.mean(axis=0)) <= SIGMAS * se).all(), (a, b, d.mean(axis=0), se)
    if name != "furnace":    # light samples find its small light: MIS is less noisy
        assert images[MIS].std() < images[BSDF_ONLY].std()


def test_direct_light_at_depth_one_is_the_whitted_diffuse_term():
    """A point light, black sky, no emission, no ambient or highlight: the
    path tracer's one bounce is its light sample at the camera hit,
    albedo x colour x cos, which is the whitted image's diffuse term (the
    bounce ray meets only black).  Deterministic (one light point, the
    pixel centres), so equal to rounding."""
    mat = Material(color=(0.7, 0.5, 0.3), ambient=0.0, diffuse=0.9, specular=0.0)
    scene = Scene("direct", Camera(eye=(0, 1.5, 5), look_at=(0, 0.6, 0), width=24, height=18),
                  objects=[Sphere((0.0, 0.8, 0.0), 0.8, mat), Plane((0, 0, 0), (0, 1, 0), mat)],
                  lights=[Light(position=(-3.0, 5.0, 3.0), color=(1.0, 0.9, 0.8))],
                  background=(0.0, 0.0, 0.0))
    whitted = raytrace.render(scene).linear
    path = raytrace.render(scene, integrator="path", max_depth=1)
    assert path.stats["integrator"] == "path" and path.stats["counters"]["bounce_rays"] > 0
    assert whitted.max() > 0.3
    np.testing.assert_allclose(path.linear, whitted, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("sampler", ["independent", "sobol"])
def test_same_bits_for_any_tiles_threads_and_structure(sampler):
    scene = cornell(16)
    kw = dict(integrator="path", spp=2, seed=7, sampler=sampler)
    ref = raytrace.render(scene, threads=2, **kw)
    assert ref.stats["counters"]["roulette_ended"] > 0
    assert ref.stats["counters"]["emitter_samples"] > 0
    for other in (raytrace.render(scene, threads=1, accel="grid", **kw),
                  raytrace.render(scene, threads=2, accel="kdtree", **kw)):
        assert np.array_equal(other.linear, ref.linear)
    assert np.array_equal(raytrace.render(scene, tiles=3, **kw).image, ref.image)
    # Rows cut off the strips of 8 (a tile from row 5) change nothing either.
    setup = prepare(scene, RenderOptions(width=16, height=16, **kw))
    cam = camera_buffer(scene.camera, 16, 16)
    rows = [render_band(setup.payload(), cam, y0, y1, 2)[0] for y0, y1 in ((0, 5), (5, 16))]
    assert np.array_equal(np.concatenate(rows), ref.linear)


def test_scene_files_and_mtl_give_emission(tmp_path):
    from raytrace.scene.formats.materials import gltf_material, mtl_material
    from raytrace.scene.formats.mtl import parse_mtl
    mtl = parse_mtl("newmtl lamp\nKd 0.5 0.5 0.5\nKe 4 3 2\n", "x.mtl", print)["lamp"]
    assert mtl_material(mtl, Material(), "x.mtl", print).emission == (4.0, 3.0, 2.0)
    pbr = SimpleNamespace(baseColorFactor=[1.0, 1.0, 1.0, 1.0], emissiveFactor=[0.5, 2.0, -1.0])
    assert gltf_material(pbr, Material(), "x.glb", print).emission == (0.5, 2.0, 0.0)
    scene = cornell(8)
    assert scene.integrator == "path"
    assert sum(1 for o in scene.objects if max(o.material.emission) > 0) == 1


def test_bad_integrator_and_emission_are_one_line_errors(tmp_path):
    scene = cornell(8)
    with pytest.raises(RaytraceError, match="integrator"):
        raytrace.render(scene, integrator="bidirectional")
    bad = Scene("bad", Camera((0, 0, 5), (0, 0, 0)),
                objects=[Sphere((0, 0, 0), 1.0, Material(emission=(1.0, -1.0, 0.0)))])
    with pytest.raises(RaytraceError, match="emission"):
        raytrace.render(bad, integrator="path", width=4, height=4)
    r = CliRunner().invoke(main, ["cornell", "--integrator", "photon"])
    assert r.exit_code == 2 and "photon" in r.output
    text = (raytrace.scene.assets.assets_dir() / "cornell.toml").read_text()
    path = tmp_path / "neg.toml"
    path.write_text(text.replace("emission = [17.0, 12.0, 4.0]", "emission = [17.0, -12.0, 4.0]"))
    r = CliRunner().invoke(main, [str(path), "-o", str(tmp_path / "x.png")])
    assert r.exit_code == 1 and "emission" in r.output and len(r.output.strip().splitlines()) == 1


def test_a_whitted_render_imports_none_of_the_path_tracer():
    """Scenes without --integrator path compile none of it: its modules
    (with its sampler's and glossy lobe's) are not even imported (a fresh
    process; this one has them)."""
    import subprocess
    import sys
    code = ("import sys, raytrace; raytrace.render(raytrace.load_scene('teapot'), width=8, "
            "height=6); print(sorted(m for m in sys.modules if m.startswith('raytrace') and "
            "('path' in m.split('.')[-1] or m.split('.')[-1] in ('sobol', 'glossy'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_path_refuses_options_it_cannot_honour_and_writes_linear_files(tmp_path):
    """--shadows none and --light-samples mean nothing to the path tracer
    (docs/pathtracer.md): usage errors in one line, exit 2, no file.  Its
    --max-depth defaults to 16, whitted's to 5.  Its linear output keeps
    radiance above 1 (the light) in .pfm and .exr."""
    from raytrace.renderer.linear import read_pfm
    for args in (["--shadows", "none"], ["--light-samples", "16"]):
        out = tmp_path / "x.png"
        r = CliRunner().invoke(main, ["cornell", "--width", "4", "--height", "4", "-o", str(out),
                                      *args])
        assert r.exit_code == 2 and args[0] in r.output and not out.exists(), r.output
        assert "path trace" in r.output.strip().splitlines()[-1]
    scene = cornell(12)
    ref = raytrace.render(scene, spp=1)
    assert ref.stats["max_depth"] == 16
    from raytrace.renderer.driver import max_depth_of
    assert max_depth_of(RenderOptions(integrator="whitted"), scene) == 5
    r = CliRunner().invoke(main, ["cornell", "--width", "12", "--height", "12", "-o",
                                  str(tmp_path / "c.pfm")])
    assert r.exit_code == 0, r.output
    back = read_pfm(tmp_path / "c.pfm")
    assert back.max() > 1.0 and np.array_equal(back, ref.linear)
    OpenEXR = pytest.importorskip("OpenEXR")
    with OpenEXR.File(str(ref.save(tmp_path / "c.exr"))) as exr:
        assert np.array_equal(exr.channels()["RGB"].pixels, ref.linear)


def test_sobol_is_unbiased_and_less_noisy_in_the_cornell_box():
    """Owen-scrambled Sobol (--sampler sobol) estimates the same image as
    independent numbers: per pixel, its 16-sample image less a 256-sample
    independent one averages 0 within SIGMAS standard errors; and it is
    closer to that reference than 16 independent samples are (measured:
    about 2x at 16 spp, docs/benchmarks.md).  Refused under whitted."""
    scene = cornell(16)
    ref = raytrace.render(scene, spp=256, seed=11).linear.astype(np.float64)
    sob = raytrace.render(scene, spp=16, seed=1, sampler="sobol").linear.astype(np.float64)
    ind = raytrace.render(scene, spp=16, seed=1).linear.astype(np.float64)
    d = (sob - ref).reshape(-1, 3)
    assert (np.abs(d.mean(axis=0)) <= SIGMAS * d.std(axis=0, ddof=1) / np.sqrt(len(d))).all()
    assert np.sqrt(((sob - ref) ** 2).mean()) < np.sqrt(((ind - ref) ** 2).mean())
    with pytest.raises(RaytraceError, match="path tracer"):
        raytrace.render(scene, integrator="whitted", sampler="sobol")


def phong_reflectance(theta_o, n, steps=600):
    """What a plane of glossy weight 1 (exponent n) under the sky returns
    towards a view theta_o from its normal: the integral over the
    hemisphere of f cos x sky, f = (n + 2) / (2 pi) cos^n(alpha) about
    the mirror direction, the sky 0.8 + 0.2 cos(theta) (kernels/render.sky
    of a white background), by the midpoint rule."""
    th = (np.arange(steps) + 0.5) * (np.pi / 2) / steps
    ph = (np.arange(2 * steps) + 0.5) * np.pi / steps
    t, p = np.meshgrid(th, ph, indexing="ij")
    w = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], axis=-1)
    r = np.array([np.sin(theta_o), np.cos(theta_o), 0.0])     # the view mirrored about y
    c = np.clip(w @ r, 0.0, None)
    f = (n + 2) / (2 * np.pi) * c ** n
    return float(np.sum(f * np.cos(t) * (0.8 + 0.2 * np.cos(t)) * np.sin(t))
                 * (np.pi / 2 / steps) * (np.pi / steps))


@pytest.mark.parametrize("theta", [20.0, 70.0])
def test_glossy_lobe_returns_its_integral(theta):
    """A glossy plane (glossy 1, diffuse 0, exponent 10) under a white sky,
    seen from theta off its normal through a narrow camera: every path is
    one glossy bounce into the sky, so the pixels' mean estimates the
    lobe's integral of f cos x sky (phong_reflectance), whatever its
    sampling; within SIGMAS standard errors.  A wrong normalisation
    ((n + 1) for (n + 2): 8%), a sampling density that is not the one
    divided by, or a lobe not cut at the horizon (at 70 degrees a fifth
    of it falls below), all fail it."""
    t = np.radians(theta)
    mat = Material(color=(0.5, 0.5, 0.5), ambient=0.0, diffuse=0.0, specular=0.0,
                   shininess=10.0, glossy=1.0)
    eye = (-5.0 * np.sin(t), 5.0 * np.cos(t), 0.0)
    scene = Scene("glossy", Camera(eye=eye, look_at=(0.0, 0.0, 0.0), fov=0.2, width=4, height=4),
                  objects=[Plane((0, 0, 0), (0, 1, 0), mat)], background=(1.0, 1.0, 1.0))
    img = raytrace.render(scene, integrator="path", spp=256, max_depth=1).linear[..., 0]
    expected = phong_reflectance(t, 10.0)
    se = img.std(ddof=1) / np.sqrt(img.size)
    assert abs(img.mean() - expected) <= SIGMAS * se, (img.mean(), expected, se)
    assert 0.25 < expected < 1.0      # the lobe does reflect, less at grazing views
