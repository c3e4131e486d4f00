"""Packets of rays through the BVH (accel/bvh/packet.py): neighbouring rays
traced together give every ray the answer it gets alone, bit for bit, and
rays that cannot go together take the single-ray path."""
import numpy as np
import pytest

from raytrace import RayScene, RaytraceError
from raytrace.cast.cameras import create_rays_pinhole
from raytrace.kernels.jit import python_callable
from raytrace.kernels.lowlevel import PACKET
from raytrace.kernels.query import PACKED, SPARSE
from raytrace.scene.builtin import teapot
from raytrace.scene.model import Camera, Plane, Scene, Sphere


def _teapot_scene():
    """The teapot (triangles), a sphere and the ground plane: every kind of
    primitive a leaf or the plane pass may hold."""
    t = teapot(4)
    meshes = [o for o in t.objects if not isinstance(o, (Sphere, Plane))]
    return Scene("packets", Camera((0, 2, 6), (0, 0.7, 0)),
                 meshes + [Sphere((1.2, 0.5, 0.8), 0.4), Plane((0, 0, 0), (0, 1, 0))],
                 lights=t.lights)


def _same(a, b):
    for name in ("t", "prim_id", "geometry_id", "u", "v"):
        assert np.array_equal(a[name], b[name], equal_nan=True), name


@pytest.fixture(scope="module")
def scenes():
    target = _teapot_scene()
    return RayScene(target, accel="bvh"), RayScene(target, accel="none")


def test_camera_and_shadow_rays_in_packets_hit_as_brute_force(scenes):
    bvh, brute = scenes
    rays = create_rays_pinhole(50, [0, 0.7, 0], [0.3, 2.2, 5.5], [0, 1, 0], 96, 64).reshape(-1, 6)
    o, d = rays[:, :3], rays[:, 3:]
    h, ref = bvh.cast_rays(o, d), brute.cast_rays(o, d)
    _same(h, ref)
    assert h.hit.mean() > 0.5
    # One shadow ray from each hit, off the surface, to a point light.
    p = h.point[h.hit] + 1e-6 * h.normal[h.hit] * -np.sign(
        np.sum(h.normal[h.hit] * d[h.hit], axis=1, keepdims=True))
    to_light = np.array([3.0, 5.0, 4.0]) - p
    blocked = bvh.occluded(p, to_light, t_max=1.0)
    assert np.array_equal(blocked, brute.occluded(p, to_light, t_max=1.0))
    assert 0 < blocked.mean() < 1
    # Per-ray intervals: every ray its own t_min and t_max.
    rng = np.random.default_rng(3)
    t_min = rng.uniform(0, 4, len(o))
    t_max = t_min + rng.uniform(0.1, 4, len(o))
    _same(bvh.cast_rays(o, d, t_min=t_min, t_max=t_max),
          brute.cast_rays(o, d, t_min=t_min, t_max=t_max))
    assert np.array_equal(bvh.occluded(o, d, t_min=t_min, t_max=t_max),
                          brute.occluded(o, d, t_min=t_min, t_max=t_max))


def test_leaves_entered_by_one_or_two_of_a_packets_rays_hit_as_brute_force():
    """A bumpy grid of 32,768 small triangles under 64x64 camera rays: a
    packet's neighbouring rays lie about a leaf's width apart, so the
    packets share the upper nodes (and stay packets) while most leaves are
    entered by one or two of their rays and tested ray by ray
    (packet.ALONE_MAX), the rest triangle by triangle.  Closest hits, and
    any hit with intervals cut at and just past each hit, as brute force
    (a ray alone's u left unwritten, or its any hit given to its
    neighbour, fails this)."""
    from raytrace.accel.bvh.packet import ALONE_MAX
    assert ALONE_MAX >= 1
    n = 128
    x, z = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-1, 1, n + 1))
    y = 0.05 * np.sin(7 * x) * np.cos(5 * z)
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    f = np.concatenate([np.column_stack([i, i + 1, i + n + 2]),
                        np.column_stack([i, i + n + 2, i + n + 1])])
    bvh, brute = RayScene((v, f), accel="bvh"), RayScene((v, f), accel="none")
    rays = create_rays_pinhole(40, [0, 0, 0], [0.2, 2.0, 0.3], [0, 0, -1], 64, 64).reshape(-1, 6)
    o, d = rays[:, :3], rays[:, 3:]
    h = bvh.cast_rays(o, d)
    _same(h, brute.cast_rays(o, d))
    assert h.hit.all()
    for t_max in (h.t, np.nextafter(h.t, np.inf)):
        assert np.array_equal(bvh.occluded(o, d, t_max=t_max), brute.occluded(o, d, t_max=t_max))
    assert not bvh.occluded(o, d, t_max=h.t).any() and bvh.occluded(o, d, t_max=h.t * 1.01).all()


def _octahedron():
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5],
                  [0, 3, 5]])
    return v, f


def test_packets_of_rays_through_edges_and_vertices_hit_as_brute_force():
    """Parallel rays aimed exactly at an octahedron's vertices, edge
    midpoints and face centres, 16 to a packet: where a ray meets two or
    more triangles at one distance, the lowest id wins in either path."""
    v, f = _octahedron()
    targets = [v[i] for i in range(6)]
    targets += [(v[a] + v[b]) / 2 for a, b, _ in f] + [(v[b] + v[c]) / 2 for _, b, c in f]
    targets += [v[tri].mean(axis=0) for tri in f]
    targets = np.array(targets * 4)[: (len(targets) * 4) // PACKET * PACKET]
    for direction, back in (([0.0, 0.0, -1.0], 3), ([0.3, -0.2, -1.0], 3),
                            ([-0.0, 0.5, -1.0], 3), ([0.0, 0.0, -1.0], 1e19)):
        # From 1e19 away the rays lie beyond the float32 box test's range:
        # their packets enter every box, as each ray alone does.
        d = np.broadcast_to(direction, targets.shape)
        o = targets - back * d
        bvh, brute = RayScene((v, f), accel="bvh"), RayScene((v, f), accel="none")
        h = bvh.cast_rays(o, d)
        _same(h, brute.cast_rays(o, d))
        assert h.hit.all()
        assert np.array_equal(bvh.occluded(o, d), brute.occluded(o, d))


def test_which_rays_go_as_a_packet():
    """A whole packet of valid rays whose directions share their signs goes
    together and writes its answers; mixed signs (-0.0 counts as negative),
    a bad ray or a short batch go one by one, and the packet writes
    nothing."""
    from raytrace.accel.bvh.packet import closest_packet, occluded_packet
    bvh = RayScene(_teapot_scene(), accel="bvh")._built()
    closest, occluded = python_callable(closest_packet), python_callable(occluded_packet)
    rays = create_rays_pinhole(40, [0, 0.7, 0], [0, 2, 6], [0, 1, 0], PACKET, 1).reshape(-1, 6)
    o, d = rays[:, :3].copy(), rays[:, 3:].copy()
    d[:, 0] = np.abs(d[:, 0]) + 1e-3

    def run(o, d, m=PACKET):
        n = len(o)
        t_min, t_max = np.zeros(n), np.full(n, np.inf)
        out = np.full(n, -7.0), np.full(n, -7, np.int64), np.full(n, -7.0), np.full(n, -7.0)
        hit = np.zeros(n, np.bool_)
        cnt = np.zeros(16, np.int64)
        went = closest(bvh.geo, bvh.acc, o, d, t_min, t_max, 0, m, out, cnt)
        assert occluded(bvh.geo, bvh.acc, o, d, t_min, t_max, 0, m, hit, cnt) == went
        return went, out

    went, out = run(o, d)
    assert went == PACKED and (out[1] >= 0).any() and (out[0] != -7.0).all()
    flipped = d.copy()
    flipped[5, 0] = -0.0
    nan = o.copy()
    nan[9, 1] = np.nan
    for args in ((o, flipped), (nan, d), (o, d, PACKET - 1)):
        went, out = run(*args)
        assert not went and (out[1] == -7).all()



def test_a_packet_of_scattered_rays_goes_but_says_so():
    """Parallel rays from points scattered over the mesh share the signs a
    packet needs but few of its nodes: the packet goes (its answers are
    each ray's own) and returns SPARSE, so the caller sends the rest of its
    chunk ray by ray; the same rays side by side return PACKED.  Whole
    batches of either give brute force's answers and counts."""
    from raytrace.accel.bvh.packet import closest_packet, occluded_packet
    from raytrace.scene.builtin import teapot_mesh
    mesh = teapot_mesh(32)            # 65k triangles: deep enough to share little
    scene = RayScene((mesh.vertices, mesh.faces), accel="bvh")
    bvh = scene._built()
    closest, occluded = python_callable(closest_packet), python_callable(occluded_packet)
    lo, hi = bvh.bounds()
    side = np.linspace(0, 1, 64)
    y, z = np.meshgrid(lo[1] + side * (hi[1] - lo[1]), lo[2] + side * (hi[2] - lo[2]))
    o = np.column_stack([np.full(y.size, lo[0] - 1), y.ravel(), z.ravel()])
    d = np.tile([1.0, 0.0, 0.0], (len(o), 1))
    scattered = o[np.random.default_rng(3).permutation(len(o))]
    n = len(o)
    t_min, t_max = np.zeros(n), np.full(n, np.inf)
    verdicts = {}
    for name, rows in (("side by side", o), ("scattered", scattered)):
        out = np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n)
        hit = np.zeros(n, np.bool_)
        cnt = np.zeros(16, np.int64)
        verdicts[name] = [(closest(bvh.geo, bvh.acc, rows, d, t_min, t_max, i0, PACKET, out, cnt),
                           occluded(bvh.geo, bvh.acc, rows, d, t_min, t_max, i0, PACKET, hit, cnt))
                          for i0 in range(PACKET * 16, PACKET * 24, PACKET)]
    assert {v for pair in verdicts["scattered"] for v in pair} == {SPARSE}
    assert {v for pair in verdicts["side by side"] for v in pair} == {PACKED}
    brute = RayScene((mesh.vertices, mesh.faces), accel="none")
    h, h0 = scene.cast_rays(scattered, d), brute.cast_rays(scattered, d)
    assert np.array_equal(h.t, h0.t) and np.array_equal(h.prim_id, h0.prim_id)
    assert np.array_equal(scene.occluded(scattered, d), brute.occluded(scattered, d))
    assert np.array_equal(scene.count_intersections(scattered, d),
                          brute.count_intersections(scattered, d))


def test_a_bad_ray_among_coherent_ones_is_still_reported(scenes):
    bvh, _ = scenes
    rays = create_rays_pinhole(50, [0, 0.7, 0], [0, 2, 6], [0, 1, 0], 64, 4).reshape(-1, 6)
    o, d = rays[:, :3].copy(), rays[:, 3:]
    o[37, 2] = np.inf
    with pytest.raises(RaytraceError, match=r"origins\[37\]"):
        bvh.cast_rays(o, d)
    with pytest.raises(RaytraceError, match=r"origins\[37\]"):
        bvh.occluded(o, d)


def test_a_packets_rows_are_make_ray_and_box_ray_bit_for_bit():
    """packet_rays computes every ray's make_ray and box_ray at once; its
    rows must hold their values exactly, over magnitudes from vanishing
    directions to origins beyond the float32 box test's range, with zero
    and negative-zero components, ties for the dominant axis, and trees
    within and beyond that range."""
    from raytrace.accel.bvh.packet import _CONST_ROWS, _FIELD_ROWS, Packet, _load
    from raytrace.accel.bvh.traverse import box_ray
    from raytrace.kernels.ray import make_ray
    load, ray_of, box_of = (python_callable(k) for k in (_load, make_ray, box_ray))
    acc = RayScene(_octahedron(), accel="bvh")._built().acc
    rng = np.random.default_rng(11)
    shared = {"within": 0, "beyond": 0, "mixed": 0}
    for trial in range(60):
        signs = rng.choice([-1.0, 1.0], 3)
        d = signs * 10.0 ** rng.uniform(-130, 6, (PACKET, 3))
        o = rng.choice([-1.0, 1.0], (PACKET, 3)) * 10.0 ** rng.uniform(-300, 2, (PACKET, 3))
        if trial % 3 == 0:   # ties and zeros of the direction's sign
            d[::2, 1] = d[::2, 0] * signs[1] * signs[0]
            d[1::4, 2] = 0.0 * signs[2]
        if trial % 4 == 1:   # some origins beyond float32's reach, or all
            o[rng.random(PACKET) < (0.3 if trial % 8 == 1 else 1.1), 0] = 1e19
        tree = acc if trial % 5 else acc._replace(box_bound=np.inf)
        pk = Packet(np.zeros(_FIELD_ROWS), np.zeros(3 * PACKET, np.int64),
                    np.zeros(_CONST_ROWS, np.float32), np.zeros(PACKET, np.float32),
                    np.zeros(PACKET), np.zeros(PACKET), np.zeros(PACKET, np.int64),
                    np.zeros(PACKET), np.zeros(PACKET))
        t_min, t_max = rng.uniform(0, 1, PACKET), np.full(PACKET, np.inf)
        rows = load(tree, o, d, t_min, t_max, 0, pk)
        f = pk.fields.reshape(16, PACKET)
        c = pk.consts.reshape(12, PACKET)
        near = set()
        for r in range(PACKET):
            ray = ray_of(*o[r], *d[r], t_min[r])
            br = box_of(tree, ray)
            want = [ray.ox, ray.oy, ray.oz, ray.dx, ray.dy, ray.dz, ray.inv_x, ray.inv_y,
                    ray.inv_z, ray.sx, ray.sy, ray.sz, ray.okx, ray.oky, ray.okz, ray.t_min]
            assert np.array_equal(f[:, r].view(np.int64), np.array(want).view(np.int64)), r
            assert [pk.axes[r], pk.axes[PACKET + r], pk.axes[2 * PACKET + r]] == \
                [ray.kx, ray.ky, ray.kz]
            assert np.array_equal(c[:, r].view(np.int32),
                                  np.array(br[3:], np.float32).view(np.int32)), r
            near.add(tuple(br[:3]))
        shared["mixed" if len(near) > 1 else "beyond" if (tree is not acc or (
            np.abs(o).max(axis=1) > 2.0 ** 62).all()) else "within"] += 1
        assert rows == (next(iter(near)) if len(near) == 1 else (-1, -1, -1))
    assert min(shared.values()) > 0, shared


def test_rays_in_strided_arrays_go_one_by_one_with_the_same_answers():
    """The batch kernels take any layout of rays; a packet reads C rows
    only, so other layouts compile the single-ray path alone."""
    from raytrace.kernels.cast import COLUMNS, cast_closest, cast_occluded
    prepared = RayScene(_octahedron(), accel="bvh")._built()
    rays = create_rays_pinhole(40, [0, 0, 0], [0.5, 0.7, 3], [0, 1, 0], 32, 2).reshape(-1, 6)
    wide = np.zeros((len(rays), 6))
    wide[:, :3], wide[:, 3:] = rays[:, :3], rays[:, 3:]
    n = len(rays)
    answers = []
    for o, d in ((np.ascontiguousarray(rays[:, :3]), np.ascontiguousarray(rays[:, 3:])),
                 (wide[:, :3], wide[:, 3:])):
        out = np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n)
        hit = np.empty(n, np.bool_)
        t_min, t_max = np.zeros(n), np.full(n, np.inf)
        cast_closest(prepared.scene("rays"), o, d, t_min, t_max, *out,
                     np.zeros((1, COLUMNS), np.int64), np.zeros(1, np.int64))
        cast_occluded(prepared.scene("rays"), o, d, t_min, t_max, hit,
                      np.zeros((1, COLUMNS), np.int64), np.zeros(1, np.int64))
        answers.append(out + (hit,))
    assert (answers[0][1] >= 0).sum() > n // 4
    for a, b in zip(*answers):
        assert np.array_equal(a, b)


def test_small_calls_go_one_by_one_with_the_same_answers(scenes):
    """Calls of fewer than PACKET_MIN rays run kernels without the packet
    code (kernels/cast.py); each ray's answer is the one a big call gives."""
    from raytrace.kernels import cast
    bvh, _ = scenes
    rays = create_rays_pinhole(50, [0, 0.7, 0], [0.3, 2.2, 5.5], [0, 1, 0], 32, 24).reshape(-1, 6)
    o, d = rays[:, :3], rays[:, 3:]
    assert len(o) >= cast.PACKET_MIN
    whole, blocked = bvh.cast_rays(o, d), bvh.occluded(o, d, t_max=6.0)
    assert whole.hit.sum() > len(o) // 4 and blocked.any() and not blocked.all()
    step = cast.PACKET_MIN - 1
    parts = [bvh.cast_rays(o[s:s + step], d[s:s + step]) for s in range(0, len(o), step)]
    for name in ("t", "prim_id", "geometry_id", "u", "v"):
        assert np.array_equal(whole[name], np.concatenate([p[name] for p in parts]),
                              equal_nan=True), name
    assert np.array_equal(blocked, np.concatenate(
        [bvh.occluded(o[s:s + step], d[s:s + step], t_max=6.0) for s in range(0, len(o), step)]))
    # The small calls compiled the one-by-one kernels, the big ones the packet kernels.
    assert cast._closest_single.signatures and cast._closest_block.signatures


@pytest.mark.parametrize("accel", ["none", "grid"])
def test_a_structure_without_packets_runs_its_one_ray_kernels_for_big_calls(accel):
    """Only the BVH has packet traversals: a big call on another structure
    runs (and compiles) the one-ray kernels a small call runs, not a
    packet kernel that would trace every ray alone too."""
    from raytrace.kernels import cast
    scene = RayScene(_teapot_scene(), accel=accel)
    rays = create_rays_pinhole(50, [0, 0.7, 0], [0.3, 2.2, 5.5], [0, 1, 0], 32, 24).reshape(-1, 6)
    o, d = rays[:, :3], rays[:, 3:]
    assert len(o) >= cast.PACKET_MIN
    hits, blocked = scene.cast_rays(o, d), scene.occluded(o, d, t_max=6.0)
    assert hits.hit.any() and blocked.any()
    layout = type(scene._built().acc).__name__
    for kernel in (cast._closest_single, cast._occluded_single):
        assert any(f"{layout}(" in str(s) for s in kernel.signatures), kernel
    for kernel in (cast._closest_block, cast._occluded_block):
        assert not any(f"{layout}(" in str(s) for s in kernel.signatures), kernel


def test_the_one_ray_kernels_compile_no_packet_code(tmp_path):
    """A first call of a few rays compiles the one-ray kernels, whose packet
    branch Numba prunes at compile time (kernels/cast.py): the packet code
    is most of a query's compile (first cast_rays 4.0 s, 5.7-6.0 while it
    was compiled into the one-ray kernel too).  Fresh cache, so nothing
    is loaded instead of compiled."""
    import os
    import subprocess
    import sys
    script = (
        "import numpy as np, raytrace\n"
        "from raytrace.accel.bvh import packet\n"
        "from raytrace.kernels import cast\n"
        "v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float); f = np.array([[0, 1, 2]])\n"
        "o, d = np.array([[0.2, 0.2, 1.0]]), np.array([[0, 0, -1.0]])\n"
        "assert raytrace.cast_rays((v, f), o, d).hit.all()\n"
        "assert raytrace.occluded((v, f), o, d, 2.0).all()\n"
        "assert cast._closest_single.signatures and cast._occluded_single.signatures\n"
        "print(len(packet._load.signatures), len(cast._closest_block.signatures))\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), RAYTRACE_QUIET="1")
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.split() == ["0", "0"]
