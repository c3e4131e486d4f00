"""Frame sequences: a GIF, an MP4 or numbered PNGs read back as written;
an interrupted run leaves no partial output; bad paths fail before any
rendering."""
import errno
import os
import sys

import numpy as np
import pytest
from PIL import Image, ImageSequence

from raytrace.errors import RaytraceError
from raytrace.frames.writers import check_frame_output, frame_output, frame_path

H, W = 6, 10


def frames(n, h=H, w=W, colours=5):
    """n distinct images of a few colours each, exact in a GIF's palette."""
    rng = np.random.default_rng(n)
    out = []
    for _ in range(n):
        palette = rng.integers(0, 256, (colours, 3), dtype=np.uint8)
        out.append(palette[rng.integers(0, colours, (h, w))])
    return out


def files(folder):
    return sorted(os.listdir(folder))


def write_all(path, images, **kw):
    with frame_output(path, len(images), **kw) as out:
        for i, image in enumerate(images):
            if not out.complete(i):
                out.write(i, image)
    return out


def test_gif_reads_back_frame_for_frame(tmp_path):
    path = tmp_path / "spin.gif"
    images = frames(4)
    write_all(path, images, fps=25)
    assert files(tmp_path) == ["spin.gif"]
    gif = Image.open(path)
    assert gif.n_frames == 4 and gif.size == (W, H) and gif.info["loop"] == 0
    for image, frame in zip(images, ImageSequence.Iterator(gif)):
        assert frame.info["duration"] == 40
        assert np.array_equal(np.asarray(frame.convert("RGB")), image)


def _gradient(h=48, w=256, shift=0):
    """Smooth shading: far more colours than a GIF's 256."""
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([(x + shift) % w, x * 0.6 + y, 255 - x * 0.8], axis=-1)
    return np.clip(rgb, 0, 255).astype(np.uint8)


def _block_error(a, b, k=4):
    """Mean difference of k x k block averages: what the eye sees of banding."""
    h, w = (n - n % k for n in a.shape[:2])
    def blocks(m):
        return m[:h, :w].astype(float).reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))
    return np.abs(blocks(a) - blocks(b)).mean()


def test_gif_shares_one_palette_and_dithers_smooth_shading(tmp_path):
    """Frames of smooth shading come back in one set of at most 256
    colours, dithered: averaged over 4x4 blocks they are much closer to
    the render than the nearest colours of that palette (flat bands)."""
    images = [_gradient(shift=0), _gradient(shift=40)]
    write_all(tmp_path / "g.gif", images)
    back = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(Image.open(tmp_path / "g.gif"))]
    used = np.unique(np.concatenate([b.reshape(-1, 3) for b in back]), axis=0)
    assert len(used) <= 256
    palette = Image.new("P", (1, 1))
    palette.putpalette(used.ravel().tolist())
    for image, got in zip(images, back):
        banded = np.asarray(Image.fromarray(image).quantize(palette=palette, dither=Image.Dither.NONE)
                            .convert("RGB"))
        assert _block_error(got, image) < 0.5 * _block_error(banded, image)


def test_gif_plays_at_its_frame_rate(tmp_path):
    """GIF times frames in hundredths: at 24 fps they alternate 40 and 50 ms
    so that 24 frames last one second (one rounded duration gave 25 fps)."""
    write_all(tmp_path / "f.gif", frames(24), fps=24)
    durations = [f.info["duration"] for f in ImageSequence.Iterator(Image.open(tmp_path / "f.gif"))]
    assert len(durations) == 24 and sum(durations) == 1000 and set(durations) == {40, 50}


def test_gif_held_frames_keep_their_time(tmp_path):
    """Pillow merges identical frames; the animation's length stays."""
    a, b = frames(2)
    write_all(tmp_path / "h.gif", [a, b, b, b], fps=10)
    durations = [f.info["duration"] for f in ImageSequence.Iterator(Image.open(tmp_path / "h.gif"))]
    assert sum(durations) == 400


def test_png_sequence_reads_back(tmp_path):
    pattern = tmp_path / "out" / "deeper" / "spin_%03d.png"      # directories made as needed
    images = frames(12)
    write_all(pattern, images)
    names = [f"spin_{i:03d}.png" for i in range(12)]
    assert files(tmp_path / "out" / "deeper") == names
    for name, image in zip(names, images):
        assert np.array_equal(np.asarray(Image.open(tmp_path / "out" / "deeper" / name)), image)


def test_frame_numbers_unpadded_and_padded(tmp_path):
    assert frame_path(tmp_path / "a_%d.png", 12).name == "a_12.png"
    assert frame_path(tmp_path / "a_%05d_b.png", 12).name == "a_00012_b.png"
    assert frame_path("f/%02d.png", 123).as_posix() == "f/123.png"


def test_resume_skips_frames_present_and_overwrites_without_it(tmp_path):
    pattern = tmp_path / "f_%02d.png"
    old, new = frames(4), frames(5)
    with frame_output(pattern, 4) as out:
        out.write(0, old[0])
        out.write(2, old[2])
    written = []
    with frame_output(pattern, 4, resume=True) as out:
        for i in range(4):
            if out.complete(i):
                continue
            out.write(i, new[i])
            written.append(i)
    assert written == [1, 3]
    back = [np.asarray(Image.open(frame_path(pattern, i))) for i in range(4)]
    assert [np.array_equal(b, x) for b, x in zip(back, [old[0], new[1], old[2], new[3]])] == [True] * 4
    # Without resume nothing counts as complete and every frame is replaced.
    with frame_output(pattern, 4) as out:
        assert not any(out.complete(i) for i in range(4))
        for i in range(4):
            out.write(i, new[i])
    assert np.array_equal(np.asarray(Image.open(frame_path(pattern, 0))), new[0])


class Stop(BaseException):
    pass


@pytest.mark.parametrize("stop", [Stop, KeyboardInterrupt, RaytraceError])
@pytest.mark.parametrize("name", ["spin.gif", "spin.mp4"])
def test_an_exception_mid_sequence_leaves_no_file(tmp_path, name, stop):
    images = frames(6)
    with pytest.raises(stop):
        with frame_output(tmp_path / name, 6) as out:
            for i in range(3):
                out.write(i, images[i])
            raise stop("stopped")
    assert files(tmp_path) == []


def test_an_exception_mid_png_sequence_keeps_complete_frames(tmp_path, monkeypatch):
    images = frames(6)
    pattern = tmp_path / "s_%d.png"
    real_fromarray = Image.fromarray

    def fromarray(a, *args, **kw):
        if a is images[3]:
            raise KeyboardInterrupt     # while frame 3's temporary file is open
        return real_fromarray(a, *args, **kw)

    monkeypatch.setattr(Image, "fromarray", fromarray)
    with pytest.raises(KeyboardInterrupt):
        write_all(pattern, images)
    assert files(tmp_path) == ["s_0.png", "s_1.png", "s_2.png"]
    assert np.array_equal(np.asarray(Image.open(tmp_path / "s_2.png")), images[2])


def test_too_few_frames_write_nothing(tmp_path):
    with pytest.raises(RaytraceError, match=r"spin.gif: only 2 of 3 frames were written; nothing saved"):
        with frame_output(tmp_path / "spin.gif", 3) as out:
            out.write(0, frames(1)[0])
            out.write(1, frames(1)[0])
    assert files(tmp_path) == []


def test_frames_are_checked(tmp_path):
    with frame_output(tmp_path / "x.gif", 2) as out:
        with pytest.raises(RaytraceError, match=r"frame index must be an integer from 0 to 1, got 2"):
            out.write(2, frames(1)[0])
        with pytest.raises(RaytraceError, match=r"expected an \(h, w, 3\) uint8 image, got float64"):
            out.write(0, np.zeros((H, W, 3)))
        out.write(0, frames(1)[0])
        with pytest.raises(RaytraceError, match=r"frame 0 written twice"):
            out.write(0, frames(1)[0])
        with pytest.raises(RaytraceError, match=r"frame 1 is 3x2, the frames before it 10x6"):
            out.write(1, frames(1, h=2, w=3)[0])
        out.write(1, frames(1)[0])


def test_mp4_reads_back_with_an_odd_size_padded(tmp_path):
    import av  # the video extra; the test extra has it too
    images = frames(7, h=5, w=9, colours=2)
    # Written out of order: frames wait for the ones before them.
    with frame_output(tmp_path / "spin.mp4", 7, fps=12) as out:
        for i in (1, 0, 2, 3, 5, 4, 6):
            out.write(i, images[i])
    assert files(tmp_path) == ["spin.mp4"]
    with av.open(str(tmp_path / "spin.mp4")) as video:
        stream = video.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.average_rate == 12
        decoded = [f.to_ndarray(format="rgb24") for f in video.decode(stream)]
    assert len(decoded) == 7 and decoded[0].shape == (6, 10, 3)
    # Lossy, but a frame is nearer its own image than its neighbour's.
    for i in range(6):
        own = np.abs(decoded[i][:5, :9].astype(int) - images[i]).mean()
        other = np.abs(decoded[i][:5, :9].astype(int) - images[i + 1]).mean()
        assert own < other


def test_mp4_without_the_video_extra_names_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "av", None)
    with pytest.raises(RaytraceError) as info:
        frame_output(tmp_path / "spin.mp4", 3)
    assert str(info.value) == "writing .mp4 needs the video extra: pip install 'raytrace[video]'"
    assert check_frame_output(tmp_path / "spin.mp4") == "mp4"     # the path itself is fine


def test_kinds(tmp_path):
    assert check_frame_output(tmp_path / "a.gif") == "gif"
    assert check_frame_output(str(tmp_path / "a.MP4")) == "mp4"
    assert check_frame_output(tmp_path / "new" / "a_%04d.png", resume=True) == "png-sequence"
    assert not (tmp_path / "new").exists()          # checking makes nothing


BAD_PATHS = [
    ("spin.png", {}, "spin.png writes one image; for frames use .gif, .mp4 or a pattern like "
                     "frames/spin_%04d.png"),
    ("spin.jpg", {}, "spin.jpg writes one image"),
    ("spin.avi", {}, "spin.avi: unknown animation format '.avi' (use .gif, .mp4 or a pattern"),
    ("spin", {}, "spin: unknown animation format '(no extension)'"),
    ("spin_%d_%04d.png", {}, "spin_%d_%04d.png: 2 frame number fields; a pattern has exactly one"),
    ("spin_%4d.png", {}, "spin_%4d.png: frame number field %4d pads with spaces; use %d or %04d"),
    ("spin_%04d.jpg", {}, "frame sequences are written as PNG files; end the pattern in .png"),
    ("spin_%04d.gif", {}, "a .gif holds every frame in one file; drop the frame number field"),
    ("f%d/spin_%d.png", {}, "the frame number field belongs in the file name, not the directory"),
    ("spin.gif", {"resume": True}, "--resume needs a PNG sequence (a pattern like frames/spin_%04d.png); "),
    ("spin.mp4", {"resume": True}, "--resume needs a PNG sequence"),
    ("nodir/spin.gif", {}, "nodir/spin.gif: directory"),
    ("afile/spin_%d.png", {}, "afile/spin_%d.png: afile is not a directory"),
    ("afile/sub/spin_%d.png", {}, "cannot make directory afile/sub: afile is not a directory"),
    ("x" * 300 + "_%d.png", {}, "file name longer than 255 bytes"),
]


@pytest.mark.parametrize("name, kw, message", BAD_PATHS)
def test_bad_frame_outputs(tmp_path, monkeypatch, name, kw, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("")
    with pytest.raises(RaytraceError) as info:
        check_frame_output(name, **kw)
    assert message in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(RaytraceError):        # frame_output checks as well
        frame_output(name, 2, **kw)


@pytest.mark.parametrize("name", ["ro/spin.gif", "ro/spin_%d.png", "ro/new/spin_%d.png"])
def test_unwritable_directory(tmp_path, monkeypatch, name):
    """A directory that takes no new file.  Its mode cannot show it (root,
    as CI may run, writes anywhere), so the probe file fails as it would."""
    import tempfile
    (tmp_path / "ro").mkdir()

    def refused(*args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
    monkeypatch.setattr(tempfile, "mkstemp", refused)
    with pytest.raises(RaytraceError, match="cannot") as info:
        check_frame_output(tmp_path / name)
    assert "Permission denied" in str(info.value)


@pytest.mark.parametrize("fps", [0, 0.5, 241, -3, float("nan"), True, "24"])
def test_fps_is_checked(tmp_path, fps):
    with pytest.raises(RaytraceError, match="fps must be a number from 1 to 240"):
        frame_output(tmp_path / "a.gif", 2, fps=fps)


@pytest.mark.parametrize("n", [0, 100001, 2.5])
def test_frame_count_is_checked(tmp_path, n):
    with pytest.raises(RaytraceError, match="n_frames must be an integer number of frames"):
        frame_output(tmp_path / "a.gif", n)
