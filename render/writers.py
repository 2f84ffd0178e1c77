"""Frame and video writers for headless runs (DESIGN.md section 7: frames, a video).

Every file is written to a temporary name in its folder and renamed when complete, so an interrupted
run leaves each finished frame readable and never a half-written PNG, MP4 or GIF:
  * `PngSequenceWriter`: `frame_00000.png`, `frame_00001.png`, ... each renamed as soon as written
    (`encode_png`: numpy and zlib);
  * `Mp4Writer`: H.264 (libx264 at MP4_PRESET, yuv420p) through imageio-ffmpeg, streamed to
    `.<name>.<tag>.tmp.mp4` and renamed on `close()`. yuv420p needs even sizes: an odd width or
    height is padded by one pixel (the last column/row repeated);
  * `GifWriter`: frames are quantised to a 256-colour palette as they arrive (about a third of the
    RGB size in memory) and written with Pillow on `close()`, looping forever.
`make_writer(fmt, ...)` picks one by name; an unknown name is a ConfigError. `WritingThread` hands
frames to writers on a thread of its own, in order, while the caller draws the next frame (the drawing
process, render/draw_process.py: zlib's deflate and the pipe to ffmpeg release the GIL).
Frames are (H, W, 3) uint8 arrays, row 0 at the top (what the renderers return).
"""

from __future__ import annotations

import os
import queue
import struct
import threading
import time
import zlib
from pathlib import Path

import numpy as np

from core.errors import ConfigError
from core.output import temporary_beside

VIDEO_FORMATS = ("mp4", "gif", "none")
FRAME_PATTERN = "frame_{:05d}.png"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_ZLIB_LEVEL = 1  # fastest deflate: frames are written as fast as they are drawn
# libx264's speed preset: 'medium' (its default) took 12.2 ms of CPU a pot frame, 'veryfast' 6.8 ms, for
# the same file size and 42.7 against 43.2 dB PSNR; the encoder shares two cores with the drawing
MP4_PRESET = "veryfast"


def _check_frame(img: np.ndarray, size: tuple[int, int] | None, where: str) -> np.ndarray:
    img = np.asarray(img)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ConfigError(where, f"array {img.shape} {img.dtype}", "an (H, W, 3) uint8 image")
    if size is not None and img.shape[:2] != size:
        raise ConfigError(where, f"frame size {img.shape[1]}x{img.shape[0]}",
                          f"the size of the first frame, {size[1]}x{size[0]}")
    return img


def _tmp_name(path: Path, suffix: str) -> Path:
    return temporary_beside(path, f".tmp{suffix}")


def encode_png(img: np.ndarray) -> bytes:
    """An RGB frame (H, W, 3) uint8 as PNG bytes (PNG 1.2: 8-bit truecolour, no interlace, every row
    with filter type 0, zlib level PNG_ZLIB_LEVEL). Pillow's encoder at level 1 took 9.4 ms a
    640x480 frame choosing a filter per row, this 2.5 ms, and the files are as small (39 against 40
    kB a pot frame): a rendered frame's flat shading compresses as well unfiltered. Every frame of a
    drawn run is one, and its process shares two cores with the simulation."""
    h, w, _ = img.shape
    rows = np.empty((h, 1 + 3 * w), np.uint8)
    rows[:, 0] = 0  # filter type None
    rows[:, 1:] = img.reshape(h, 3 * w)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8 bits, truecolour, deflate, filters, no interlace
    return (PNG_SIGNATURE + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows.tobytes(), PNG_ZLIB_LEVEL))
            + chunk(b"IEND", b""))


def write_png(path: str | Path, img: np.ndarray) -> Path:
    """One RGB frame (H, W, 3) uint8 as a PNG (`encode_png`), written to a temporary name and renamed."""
    final = Path(path)
    img = _check_frame(img, None, "png frame")
    tmp = _tmp_name(final, ".png")
    try:
        tmp.write_bytes(encode_png(img))
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return final


class PngSequenceWriter:
    """`folder/frame_00000.png`, ...: each frame written to a temporary name, then renamed."""

    def __init__(self, folder: str | Path, start: int = 0, pattern: str = FRAME_PATTERN) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.pattern = pattern
        self.index = int(start)
        self.count = 0
        self.paths: list[Path] = []
        self._size: tuple[int, int] | None = None

    @property
    def path(self) -> Path:
        return self.folder

    def write(self, img: np.ndarray) -> Path:
        img = _check_frame(img, self._size, "png frame")
        self._size = img.shape[:2]
        final = write_png(self.folder / self.pattern.format(self.index), img)
        self.index += 1
        self.count += 1
        self.paths.append(final)
        return final

    def close(self) -> Path:
        return self.folder

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class _RenamedOnClose:
    """Common part of the video writers: a temporary file renamed to `path` on a clean close()."""

    suffix = ""

    def __init__(self, path: str | Path, fps: float) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() != self.suffix:
            raise ConfigError("video path", str(self.path), f"a file name ending in '{self.suffix}'")
        if not 0.1 <= fps <= 240.0:
            raise ConfigError("video.fps", fps, "0.1 .. 240 frames per second")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fps = float(fps)
        self.count = 0
        self._size: tuple[int, int] | None = None
        self._tmp = _tmp_name(self.path, self.suffix)
        self._closed = False

    def _finish(self) -> None:
        raise NotImplementedError

    def close(self) -> Path:
        """Finish the file and rename it into place; with no frame written, nothing is left behind."""
        if self._closed:
            return self.path
        self._closed = True
        try:
            if self.count == 0:
                self._abort()
                return self.path
            self._finish()
            os.replace(self._tmp, self.path)
        except BaseException:
            self._tmp.unlink(missing_ok=True)
            raise
        return self.path

    def _abort(self) -> None:
        self._tmp.unlink(missing_ok=True)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:  # an interrupted run leaves no half-written video
            self._closed = True
            self._abort()
        return False


class Mp4Writer(_RenamedOnClose):
    """H.264 MP4 (libx264, yuv420p) through imageio-ffmpeg; odd sizes are padded to even."""

    suffix = ".mp4"

    def __init__(self, path: str | Path, fps: float = 30.0, quality: float = 7.0) -> None:
        super().__init__(path, fps)
        self.quality = float(quality)
        self._gen = None

    def write(self, img: np.ndarray) -> None:
        import imageio_ffmpeg

        img = _check_frame(img, self._size, "mp4 frame")
        if self._gen is None:
            self._size = img.shape[:2]
            h, w = self._size
            self.frame_size = (w + (w & 1), h + (h & 1))  # (W, H) written: even for yuv420p
            self._gen = imageio_ffmpeg.write_frames(
                str(self._tmp), self.frame_size, fps=self.fps, codec="libx264", pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p", quality=self.quality, macro_block_size=1, ffmpeg_log_level="error",
                output_params=["-preset", MP4_PRESET, "-f", "mp4"],
            )
            self._gen.send(None)
        w, h = self.frame_size
        if img.shape[:2] != (h, w):
            img = np.pad(img, ((0, h - img.shape[0]), (0, w - img.shape[1]), (0, 0)), mode="edge")
        self._gen.send(np.ascontiguousarray(img))
        self.count += 1

    def _finish(self) -> None:
        self._gen.close()
        self._gen = None

    def _abort(self) -> None:
        if self._gen is not None:
            try:
                self._gen.close()
            except Exception:  # noqa: BLE001 - ffmpeg may already be gone; the file is removed anyway
                pass
            self._gen = None
        super()._abort()


class GifWriter(_RenamedOnClose):
    """Animated GIF (Pillow), 256-colour palette per frame, looping; written on close()."""

    suffix = ".gif"

    def __init__(self, path: str | Path, fps: float = 30.0) -> None:
        super().__init__(path, fps)
        self._frames: list = []

    def write(self, img: np.ndarray) -> None:
        from PIL import Image

        img = _check_frame(img, self._size, "gif frame")
        self._size = img.shape[:2]
        self._frames.append(Image.fromarray(img, "RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT))
        self.count += 1

    def _finish(self) -> None:
        first, rest = self._frames[0], self._frames[1:]
        duration_ms = max(int(round(1000.0 / self.fps)), 20)  # GIF delays are centiseconds; 20 ms minimum
        first.save(self._tmp, format="GIF", save_all=True, append_images=rest, duration=duration_ms, loop=0,
                   optimize=False, disposal=1)
        self._frames = []

    def _abort(self) -> None:
        self._frames = []
        super()._abort()


def make_writer(fmt: str, out_dir: str | Path, fps: float = 30.0, stem: str = "video"):
    """A video writer by name: 'mp4' -> out_dir/stem.mp4, 'gif' -> out_dir/stem.gif, 'png' -> a frame
    sequence in out_dir/frames/, 'none' -> None."""
    key = str(fmt).lower()
    out_dir = Path(out_dir)
    if key == "mp4":
        return Mp4Writer(out_dir / f"{stem}.mp4", fps)
    if key == "gif":
        return GifWriter(out_dir / f"{stem}.gif", fps)
    if key == "png":
        return PngSequenceWriter(out_dir / "frames")
    if key == "none":
        return None
    raise ConfigError("--video", fmt, "mp4, gif, png or none")


class WritingThread:
    """Frames written by `writers` on one thread of its own, in the order given, while the caller draws
    the next: `submit(img)` returns once fewer than `ahead` frames wait before it. An error a writer
    raises stops the writing (no later frame is written) and is raised again by the next `submit` or by
    `close`, which waits for every frame submitted before it. `first_written_unix`: when the first writer
    (the drawing process's PNG sequence) wrote the first frame (time.time()), else None."""

    def __init__(self, writers, ahead: int = 1) -> None:
        self.writers = [w for w in writers if w is not None]
        self.first_written_unix: float | None = None
        self._queue: queue.Queue = queue.Queue(maxsize=max(1, int(ahead)))
        self._error: BaseException | None = None  # raised once, by the caller's thread
        self._failed = False  # a writer raised: nothing more is written
        self._thread = threading.Thread(target=self._run, name="frame-writer", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (img := self._queue.get()) is not None:
            if self._failed:
                continue  # after an error nothing more is written: the frames left are dropped
            try:
                for k, w in enumerate(self.writers):
                    w.write(img)
                    if k == 0 and self.first_written_unix is None:
                        self.first_written_unix = time.time()
            except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread, raised there
                self._failed, self._error = True, exc

    def submit(self, img: np.ndarray) -> None:
        self._raise()
        self._queue.put(img)

    def close(self) -> None:
        """Wait for the frames submitted, then raise a writer's error if one was raised (the writers
        themselves are the caller's to close)."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self._raise()

    def _raise(self) -> None:
        if self._error is not None:
            exc, self._error = self._error, None
            raise exc
