"""Notebook display and saving: render results, frames and scenes show
themselves briefly, and save in the format their file name says."""
import io

import numpy as np
import pytest
from PIL import Image

import raytrace
from raytrace.errors import RaytraceError
from raytrace.renderer.linear import read_pfm


def test_result_shows_as_png_and_a_short_repr(spheres_scene, render_small):
    r = render_small(spheres_scene)
    png = r._repr_png_()
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png))), r.image)
    text = repr(r)
    assert text.startswith("RenderResult(96x72, scene='spheres', accel='bvh'") and len(text) < 200
    assert "\n" not in text


@pytest.mark.parametrize("ext", [".png", ".npy", ".pfm"])
def test_result_saves_by_extension(spheres_scene, render_small, tmp_path, ext):
    r = render_small(spheres_scene)
    path = r.save(tmp_path / f"img{ext}")
    if ext == ".png":
        assert np.array_equal(np.asarray(Image.open(path)), r.image)
    else:
        back = np.load(path) if ext == ".npy" else read_pfm(path)
        assert back.dtype == np.float32 and np.array_equal(back, r.linear)
    assert [p.name for p in tmp_path.iterdir()] == [f"img{ext}"]      # no temporary left


def test_save_refuses_unknown_formats_and_a_tiled_linear_image(spheres_scene, tmp_path):
    r = raytrace.render(spheres_scene, tiles=2, width=16, height=12)
    with pytest.raises(RaytraceError, match="no linear image"):
        r.save(tmp_path / "x.pfm")
    with pytest.raises(RaytraceError, match="unknown image format"):
        r.save(tmp_path / "x.xyz")
    assert list(tmp_path.iterdir()) == []


def test_frames_show_as_a_strip_and_save(spheres_scene, tmp_path):
    frames, _ = raytrace.render_frames(spheres_scene, turntable=3, width=16, height=12)
    assert repr(frames) == "Frames(3 frames of 16x12)"
    strip = np.asarray(Image.open(io.BytesIO(frames._repr_png_())))
    assert strip.shape == (12, 48, 3) and np.array_equal(strip[:, 16:32], frames[1])
    gif = Image.open(frames.save(tmp_path / "spin.gif"))
    assert gif.n_frames == 3


def test_scene_and_mesh_reprs_are_one_short_line():
    scene = raytrace.load_scene("teapot", detail=16)
    text = repr(scene)
    assert text == ("Scene('teapot': 1 mesh, 1 plane (16,384 triangles); 1 light; camera 640x480)"), text
    assert repr(scene.objects[0]).startswith("Mesh('teapot': ")
    assert "array" not in repr(scene.objects[0])


def test_exr_holds_the_linear_image(spheres_scene, render_small, tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")       # the exr extra (in the test extra)
    r = render_small(spheres_scene)
    with OpenEXR.File(str(r.save(tmp_path / "img.exr"))) as exr:
        assert np.array_equal(exr.channels()["RGB"].pixels, r.linear)
