"""Frame and video writers: names, read-back (frame count, size, content), atomic renames, errors."""

from __future__ import annotations

import gc
import warnings

import numpy as np
import pytest

from core.errors import ConfigError
from render.writers import GifWriter, Mp4Writer, PngSequenceWriter, WritingThread, make_writer, write_png


def _frames(n: int, w: int, h: int) -> list[np.ndarray]:
    """Frames with a bright square that moves right by 4 px per frame on a dark background."""
    out = []
    for k in range(n):
        img = np.full((h, w, 3), 30, np.uint8)
        img[h // 4 : h // 4 + 12, 4 * k : 4 * k + 12] = (240, 200, 40)
        out.append(img)
    return out


def _no_temporaries(folder) -> bool:
    return not any(p.name.startswith(".") for p in folder.iterdir())


def _read_mp4(path) -> tuple[dict, tuple, list]:
    """(metadata, (W, H), frames) of an MP4, read back with imageio's ffmpeg backend."""
    import imageio_ffmpeg

    with warnings.catch_warnings():  # imageio-ffmpeg's reader leaves its pipes to the garbage collector
        warnings.simplefilter("ignore", ResourceWarning)
        gen = imageio_ffmpeg.read_frames(str(path))
        meta = next(gen)
        size = tuple(meta["size"])  # (W, H)
        got = [np.frombuffer(b, np.uint8).reshape(size[1], size[0], 3) for b in gen]
        gen.close()
        del gen
        gc.collect()
    return meta, size, got


def test_png_sequence(tmp_path):
    frames = _frames(4, 48, 32)
    with PngSequenceWriter(tmp_path / "frames") as w:
        for f in frames:
            w.write(f)
    import imageio.v3 as iio

    names = sorted(p.name for p in (tmp_path / "frames").iterdir())
    assert names == [f"frame_{k:05d}.png" for k in range(4)]
    for k, f in enumerate(frames):
        assert np.array_equal(iio.imread(tmp_path / "frames" / names[k]), f)  # PNG is lossless


def test_png_interrupted_run_keeps_finished_frames(tmp_path):
    """Without close() (a killed run), every frame written so far is complete and readable."""
    import imageio.v3 as iio

    w = PngSequenceWriter(tmp_path)
    for f in _frames(3, 40, 30):
        w.write(f)
    del w
    assert len(list(tmp_path.glob("frame_*.png"))) == 3 and _no_temporaries(tmp_path)
    assert iio.imread(tmp_path / "frame_00002.png").shape == (30, 40, 3)


@pytest.mark.parametrize("w,h", [(1, 1), (7, 3), (640, 480)])
def test_png_encoder_reads_back_exactly_with_pillow_and_imageio(tmp_path, w, h):
    """`encode_png` writes a PNG the reference readers decode to the same pixels, byte for byte, and
    Pillow's structural check (chunk CRCs, header) accepts."""
    import imageio.v3 as iio
    from PIL import Image

    from render.writers import encode_png

    img = np.random.default_rng(w * h).integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    path = write_png(tmp_path / "f.png", img)
    assert path.read_bytes() == encode_png(img)
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.mode == "RGB" and im.size == (w, h) and np.array_equal(np.asarray(im), img)
    assert np.array_equal(iio.imread(path), img)


@pytest.mark.parametrize("w,h", [(64, 48), (65, 47)])
def test_mp4_reads_back(tmp_path, w, h):
    """H.264 MP4 (yuv420p): frame count, size (odd sizes padded to even) and content survive a read-back."""
    frames = _frames(6, w, h)
    path = tmp_path / "run.mp4"
    with Mp4Writer(path, fps=10) as wr:
        for f in frames:
            wr.write(f)
        assert not path.exists()  # renamed into place only on close
    assert path.exists() and _no_temporaries(tmp_path)
    meta, size, got = _read_mp4(path)
    assert meta["codec"] == "h264" and len(got) == len(frames)
    assert size == (w + (w & 1), h + (h & 1))
    for f, g in zip(frames, got):  # lossy, but the moving square is where it should be
        err = np.abs(g[:h, :w].astype(int) - f.astype(int)).mean()
        assert err < 6.0


def test_gif_reads_back(tmp_path):
    import imageio.v3 as iio

    frames = _frames(5, 50, 30)
    path = tmp_path / "run.gif"
    with GifWriter(path, fps=20) as wr:
        for f in frames:
            wr.write(f)
    assert _no_temporaries(tmp_path)
    got = iio.imread(path, index=None)
    assert got.shape[0] == 5 and got.shape[1:3] == (30, 50)
    for f, g in zip(frames, got):
        assert np.abs(g[..., :3].astype(int) - f.astype(int)).max() <= 8  # two colours: exact palette


def test_video_interrupted_leaves_no_file(tmp_path):
    """An exception inside the writer's block removes the partial video instead of renaming it."""
    for cls, name in ((Mp4Writer, "a.mp4"), (GifWriter, "a.gif")):
        with pytest.raises(RuntimeError):
            with cls(tmp_path / name, fps=10) as wr:
                wr.write(_frames(1, 32, 32)[0])
                raise RuntimeError("interrupted")
        assert not (tmp_path / name).exists()
    assert list(tmp_path.iterdir()) == []


def test_make_writer_and_errors(tmp_path):
    assert isinstance(make_writer("mp4", tmp_path), Mp4Writer)
    assert isinstance(make_writer("GIF", tmp_path), GifWriter)
    assert isinstance(make_writer("png", tmp_path), PngSequenceWriter)
    assert make_writer("none", tmp_path) is None
    with pytest.raises(ConfigError, match="--video"):
        make_writer("avi", tmp_path)
    with pytest.raises(ConfigError, match="fps"):
        Mp4Writer(tmp_path / "x.mp4", fps=0)
    with pytest.raises(ConfigError, match="video path"):
        GifWriter(tmp_path / "x.mp4")
    w = PngSequenceWriter(tmp_path / "f")
    w.write(_frames(1, 20, 10)[0])
    with pytest.raises(ConfigError, match="size"):
        w.write(_frames(1, 22, 10)[0])
    with pytest.raises(ConfigError, match="uint8"):
        w.write(np.zeros((10, 20, 3), np.float32))


def test_outputs_get_a_plain_files_mode_not_the_temporary_names(tmp_path):
    """Written under a temporary name (mkstemp: mode 0600) and renamed: the output still gets the
    mode the umask gives a plain file, so other users of a shared server can read the frames."""
    import os
    import stat

    from core.output import atomic_write_json

    old = os.umask(0o022)
    try:
        write_png(tmp_path / "f.png", np.zeros((4, 6, 3), np.uint8))
        atomic_write_json(tmp_path / "stats.json", {"a": 1})
    finally:
        os.umask(old)
    for name in ("f.png", "stats.json"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644, name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png", "stats.json"]


def test_writing_thread_writes_every_frame_in_order_and_close_waits(tmp_path):
    """The drawing process's writer thread: the frames read back are the ones submitted, in order, each
    in the PNG sequence and the MP4, once close() has returned (it waits for the last)."""
    import imageio.v3 as iio

    frames = _frames(6, 48, 32)
    png, mp4 = PngSequenceWriter(tmp_path / "frames"), Mp4Writer(tmp_path / "v.mp4", fps=10)
    writing = WritingThread([png, mp4, None], ahead=1)
    for img in frames:
        writing.submit(img)
    writing.close()
    mp4.close()
    assert writing.first_written_unix is not None
    assert [p.name for p in sorted((tmp_path / "frames").iterdir())] == [f"frame_{k:05d}.png" for k in range(6)]
    for k, img in enumerate(frames):
        assert np.array_equal(iio.imread(tmp_path / "frames" / f"frame_{k:05d}.png"), img)
    assert len(_read_mp4(tmp_path / "v.mp4")[2]) == 6


def test_writing_thread_raises_a_writers_error_and_writes_nothing_after_it(tmp_path):
    class Failing:
        def __init__(self) -> None:
            self.written = 0

        def write(self, img) -> None:
            if self.written == 2:
                raise OSError("disk full")
            self.written += 1

    failing = Failing()
    writing = WritingThread([failing], ahead=1)
    with pytest.raises(OSError, match="disk full"):
        for img in _frames(8, 16, 16):  # raised by a later submit, once the thread has met it
            writing.submit(img)
        writing.close()
    writing.close()  # raised once: closing again waits for nothing and raises nothing
    assert failing.written == 2
    assert writing.first_written_unix is not None
