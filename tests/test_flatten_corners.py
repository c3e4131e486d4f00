"""Big meshes' corners are gathered and tested on every thread
(scene/corners.py): the same triangles kept, the same bits, as the
NumPy path small meshes take."""
import numba
import numpy as np
import pytest

import raytrace.scene.flatten as flatten_module
from raytrace.scene.flatten import _kept_corners, _kept_corners_parallel, flatten
from raytrace.scene.model import Mesh, Scene


def awkward_mesh(seed, n_faces=20_000):
    """Faces of every kind degenerate_mask decides: ordinary, slivers
    (kept), collinear up to rounding (areas of rounding size, dropped),
    repeated vertices, and rows too large or small to square (its rescaled
    path)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(5_000, 3))
    v[:100] = v[100:200] + 1e-7 * rng.normal(size=(100, 3))   # near twins: slivers
    v[200:300] = v[300:400] * 2.0 - v[400:500]                  # collinear triples
    v[500:550] *= 1e75                                          # beyond squaring
    v[550:600] *= 1e-75
    f = rng.integers(0, len(v), size=(n_faces, 3))
    f[:300, 0], f[:300, 1] = np.arange(300), np.arange(100, 400)
    f[300:400] = np.stack([np.arange(200, 300), np.arange(300, 400), np.arange(400, 500)], 1)
    f[400:500, 2] = f[400:500, 0]                                # a repeated vertex
    f[500:700] = rng.integers(500, 550, size=(200, 3))
    f[700:900] = rng.integers(550, 600, size=(200, 3))
    return v, f


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("seed", [0, 1])
def test_parallel_corners_are_the_numpy_ones(seed, threads):
    v, f = awkward_mesh(seed)
    want = _kept_corners(v, f)
    got = _kept_corners_parallel(v, np.ascontiguousarray(f.T), threads)
    assert 0 < np.count_nonzero(~want[3]) < len(f)     # some dropped, some kept
    for a, b in zip(want, got):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_flatten_takes_the_parallel_path_for_big_meshes(monkeypatch):
    """The same Geometry through either path (PARALLEL_MIN lowered to reach
    the threads with a small mesh), and the path really taken."""
    v, f = awkward_mesh(2, 5_000)
    scene = Scene("m", None, [Mesh(v, f)])
    small, _, info_small = flatten(scene)
    calls = []
    real = flatten_module._kept_corners_parallel
    monkeypatch.setattr(flatten_module, "_kept_corners_parallel",
                        lambda *a: calls.append(1) or real(*a))
    monkeypatch.setattr(flatten_module, "PARALLEL_MIN", 1_000)
    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)     # on a 1-core machine too
    big, _, info_big = flatten(scene)
    assert calls and info_small == info_big
    for a, b in zip(small, big):
        assert np.array_equal(a, b)


def test_big_mesh_kernels_compile_in_the_compile_phase(monkeypatch):
    """A big mesh's corners and boxes kernels are first called in the
    compile phase (driver.prepare: load_corners before flattening,
    Structure.load's load_big before the build), with the argument types of
    the real calls, so those find them compiled: flattening and build times
    hold no compile time."""
    import raytrace.accel.bvh.boxes as boxes_module
    import raytrace.accel.bvh.build as bvh_module
    import raytrace.accel.registry as structures
    from raytrace.renderer.driver import RenderOptions, prepare
    from raytrace.scene import corners
    from raytrace.scene.model import Camera
    events = []

    def spy(module, name):
        real = getattr(module, name)

        def wrapper(*args):
            events.append((name, tuple(numba.typeof(a) for a in args)))
            return real(*args)
        monkeypatch.setattr(module, name, wrapper)

    def mark(module, name):
        real = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, **k: events.append((name, None)) or real(*a, **k))
    for module, name in ((corners, "classify"), (corners, "gather"),
                         (bvh_module, "box_bounds_kernel"), (boxes_module, "box_bounds_kernel")):
        spy(module, name)
    mark(flatten_module, "flatten")
    mark(structures, "build_structure")
    monkeypatch.setattr(flatten_module, "PARALLEL_MIN", 1_000)
    monkeypatch.setattr(bvh_module, "PARALLEL_MIN", 1_000)
    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)
    v, f = awkward_mesh(3, 3_000)
    scene = Scene("m", Camera((0, 0, 50), (0, 0, 0)), [Mesh(v * 1e-3, f)])
    prepare(scene, RenderOptions(width=8, height=8, threads=2))
    names = [name for name, _ in events]
    for kernel, phase in (("classify", "flatten"), ("gather", "flatten"),
                          ("box_bounds_kernel", "build_structure")):
        calls = [k for k, name in enumerate(names) if name == kernel]
        assert calls and calls[0] < names.index(phase) < calls[-1], (kernel, names)
        assert len({events[k][1] for k in calls}) == 1, (kernel, [events[k][1] for k in calls])


def test_dropped_faces_leave_the_normal_rows_and_the_callers_arrays_alone():
    """With degenerate faces dropped, the kept faces are copied as int32
    and offset in place (flatten): two meshes' normal rows are those of the
    NumPy reference, and neither mesh's faces array (int32 or int64) changes."""
    v, f = awkward_mesh(4, 2_000)
    normals = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    meshes = [Mesh(v, f.astype(np.int32), normals=normals), Mesh(v, f.copy(), normals=normals)]
    before = [m.faces.copy() for m in meshes]
    geo, _, info = flatten(Scene("m", None, meshes))
    keep = _kept_corners(v, f)[3]
    want = np.concatenate([f[keep], f[keep] + len(v)])
    assert info["degenerate_dropped"] == 2 * np.count_nonzero(~keep) > 0
    assert geo.tri_normal.dtype == np.int32 and np.array_equal(geo.tri_normal, want)
    assert all(np.array_equal(m.faces, b) and m.faces.dtype == b.dtype
               for m, b in zip(meshes, before))
