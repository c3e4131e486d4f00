"""Rays traced in a coherent order when they come in an incoherent one
(cast/ordering.py, kernels/ray_order.py): the same answers, bit for bit,
as the rays traced in the order given; which calls are ordered."""
import numpy as np
import pytest

import raytrace
from raytrace import RayScene, RaytraceError
from raytrace.cast import ordering

N = ordering.ORDER_MIN


def _teapot(detail=4):
    mesh = raytrace.load_scene("teapot", detail=detail).objects[0]
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def _towards_the_box(v, n, seed, eye=(0.5, 0.7, 1.0), spread=2.0):
    """n rays from one point towards random points of the mesh's box, in
    a random order: neighbours apart, but alike once sorted."""
    rng = np.random.default_rng(seed)
    lo, hi = v.min(axis=0), v.max(axis=0)
    origin = (lo + hi) / 2 + np.array(eye) * spread * np.linalg.norm(hi - lo)
    targets = lo + rng.random((n, 3)) * (hi - lo)
    return np.tile(origin, (n, 1)), targets - origin


@pytest.fixture
def calls(monkeypatch):
    """The windows each ordered call traced (0 for a call traced as given),
    and a switch that turns ordering off."""
    made = []
    real = ordering.trace_in_order

    def spy(key, trace, rays, uniform, answers, threads):
        made.append(len(ordering.windows(len(rays[0]), threads)))
        return real(key, trace, rays, uniform, answers, threads)
    monkeypatch.setattr(ordering, "trace_in_order", spy)

    def off():
        monkeypatch.setattr(ordering, "decide", lambda *a: None)
    return made, off


def _answers(s, o, d, **kw):
    h = s.cast_rays(o, d, **kw)
    return [h[k].view(np.int64) if h[k].dtype == np.float64 else h[k]
            for k in ("t", "prim_id", "u", "v")] + [s.occluded(o, d, **kw),
                                                     s.count_intersections(o, d, **kw)]


@pytest.mark.parametrize("layout", ["rows of 3", "rows of 6", "float32 rows of 6"])
def test_rays_put_in_order_get_the_answers_of_the_order_given(calls, layout):
    made, off = calls
    v, f = _teapot()
    o, d = _towards_the_box(v, N, seed=1)
    if layout != "rows of 3":
        rows = np.concatenate([o, d], axis=1)
        rows = rows.astype(np.float32) if layout.startswith("float32") else rows
        o, d = rows, None
    s = RayScene((v, f))
    ordered = _answers(s, o, d)
    assert made and all(w >= 1 for w in made)
    off()
    given = _answers(s, o, d)
    assert len(made) == 3            # the three queries ordered, then none
    for a, b in zip(ordered, given):
        assert np.array_equal(a, b)
    assert given[1].min() == -1 and given[1].max() >= 0     # misses and hits
    assert given[-1].max() >= 2                             # rays through the teapot


def test_bounds_over_the_rays_go_with_their_rays(calls):
    made, off = calls
    v, f = _teapot()
    o, d = _towards_the_box(v, N, seed=2)
    rng = np.random.default_rng(3)
    t_min = rng.uniform(0.0, 0.9, N)
    t_max = t_min + rng.uniform(0.05, 1.2, N)
    s = RayScene((v, f))
    ordered = _answers(s, o, d, t_min=t_min, t_max=t_max)
    off()
    given = _answers(s, o, d, t_min=t_min, t_max=t_max)
    assert len(made) == 3
    for a, b in zip(ordered, given):
        assert np.array_equal(a, b)
    assert (given[1] != s.cast_rays(o, d).prim_id).any()     # the bounds matter


def test_which_calls_are_ordered(calls):
    """Not: rays in image order (neighbours alike already), rays from
    points spread in space in all directions (too many coordinates vary
    for a call of this size to fill the key's cells), a call of fewer than
    ORDER_MIN rays, a structure of fewer than PRIMS_MIN primitives."""
    made, _ = calls
    v, f = _teapot()
    s = RayScene((v, f))
    rng = np.random.default_rng(4)
    lo, hi = v.min(axis=0), v.max(axis=0)
    rays = raytrace.create_rays_pinhole(60, (lo + hi) / 2, (lo + hi) / 2 + [0, 0, 3], [0, 1, 0],
                                        256, 256).reshape(-1, 6)
    s.cast_rays(rays)
    spread = lo + rng.random((N, 3)) * (hi - lo)
    s.cast_rays(spread, rng.normal(size=(N, 3)))
    o, d = _towards_the_box(v, N - 1, seed=5)
    s.cast_rays(o, d)
    assert made == []
    small = _teapot(detail=1)
    assert len(small[1]) < ordering.PRIMS_MIN
    o, d = _towards_the_box(small[0], N, seed=6)
    RayScene(small).cast_rays(o, d)
    assert made == []
    o, d = _towards_the_box(v, N, seed=6)
    s.cast_rays(o, d)
    assert len(made) == 1


def test_a_bad_ray_among_ordered_ones_is_named_by_its_own_row(calls):
    made, _ = calls
    v, f = _teapot()
    o, d = _towards_the_box(v, N, seed=7)
    d[40_000] = 0.0
    with pytest.raises(RaytraceError, match=r"directions\[40000\]: zero vector"):
        RayScene((v, f)).cast_rays(o, d)
    assert made == [made[0]]


def test_windows_cover_the_call_once():
    for n, threads in ((65_536, 1), (65_536, 2), (1_000_003, 2), (5, 4)):
        spans = ordering.windows(n, threads)
        assert spans[0][0] == 0 and spans[-1][1] == n
        assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
        assert len(spans) >= threads
        assert max(hi - lo for lo, hi in spans) <= max(ordering.WINDOW_MAX, -(-n // threads))


def test_warm_compiles_what_an_ordered_call_runs():
    """After ordering.warm (raytrace warmup's queries step), ordered calls
    of float64 and float32 rays add no specialisation to its kernels."""
    from raytrace.kernels import ray_order
    kernels = (ray_order.order_window, ray_order.put_back_closest, ray_order.put_back_column,
               ray_order.neighbours_apart, ray_order.sample_coords, ray_order.sample_keys)
    ordering.warm()
    compiled = [set(map(str, k.signatures)) for k in kernels]
    v, f = _teapot()
    o, d = _towards_the_box(v, N, seed=8)
    s = RayScene((v, f))
    for rays in ((o, d), (np.concatenate([o, d], axis=1).astype(np.float32), None)):
        s.cast_rays(*rays)
        s.occluded(*rays, t_max=np.full(N, 2.0))
        s.count_intersections(*rays)
    assert [set(map(str, k.signatures)) for k in kernels] == compiled


def test_a_windows_buffer_starts_on_a_cache_line():
    """So that a record of 8 float64s (a ray and its bounds) is one line."""
    for nbytes in (100, 1 << 20, ordering._KEPT_MAX_BYTES + 8):
        buf = ordering._buffer(nbytes)
        assert buf.__array_interface__["data"][0] % 64 == 0 and len(buf) == nbytes
