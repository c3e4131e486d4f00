"""Big meshes' corners are gathered and tested on every thread
(kernels/corners.py): the same triangles kept, the same bits, as the
NumPy path small meshes take."""
import numba
import numpy as np
import pytest

import raytrace.flatten as flatten_module
from raytrace.flatten import _kept_corners, _kept_corners_parallel, flatten
from raytrace.scene import Mesh, Scene


def awkward_mesh(seed, n_faces=20_000):
    """Faces of every kind degenerate_mask decides: ordinary, slivers near
    the ratio, collinear, repeated vertices, and rows too large or small to
    square (its rescaled path)."""
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
