import numpy as np

from raytrace.flatten import degenerate_mask, flatten
from raytrace.scenes.builtin import teapot
from raytrace.scenes.teapot import tessellate


def test_default_tessellation_is_the_workshop_size():
    v, f, n = tessellate(4)
    assert len(f) == 32 * 4 * 4 * 2 == 1024
    dropped = degenerate_mask(v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]).sum()
    assert dropped == 32           # the lid knob's and the bottom's pole fans
    assert flatten(teapot())[2]["triangles"] == 992


def test_detail_43_gives_about_118k_triangles():
    v, f, n = tessellate(43)
    assert len(f) == 32 * 43 * 43 * 2 == 118336


def test_normals_point_outwards():
    v, f, n = tessellate(4)
    vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
    assert vol > 0                  # consistent outward winding
    # Vertex normals agree with the faces around them.
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ok = np.linalg.norm(fn, axis=1) > 0
    agree = np.einsum("ij,ij->i", fn[ok], n[f[ok, 0]]) > 0
    assert agree.mean() > 0.99
