"""Frames drawn on a second process while the simulation steps the next frame (issue 16 item 4:
both cores, where it pays; DESIGN.md section 7).

A drawn frame of the pot took about 20 ms of simulation and 48 ms of drawing and writing, one after
the other on one core. `main.py run` starts a drawing process first thing, before its own imports
(`DrawingProcess()`: the process imports Taichi meanwhile), says what to draw once Taichi runs
(`start`), and feeds it: the simulation process keeps what needs the
World (`SceneView`: which bodies a fracture changed and their particles, taken from the store; the
poses and debris read from the stores), and sends it, and each call it would make on a `RenderScene`,
as a message (`SceneFeed`); the drawing process keeps the bodies' surface blocks (their surfaces,
colours and crack lines, render/surface_blocks.py), the `RenderScene`, the renderer, the following
camera and the PNG and video writers, which write each frame on a thread of their own while the next
one is drawn (render/writers.py `WritingThread`: in session 42 the pot's 8 ms of PNG and 4 ms of
video feed a frame, 20-30% of the drawing process's frame; session 43's encoders take less). While
the World builds it compiles its renderer for the buffer sizes the scene asked for last time
(render/prewarm.py); it renders the scene once as soon as it has one, so that what is left to
compile does while the simulation takes its first step. The
fragments' surfaces it makes import no scipy (geometry/grid_search.py). Messages are written
on a thread of the simulation process (`_Sender`), so the simulation never waits on a drawing process
that is busy reading an earlier one: before, writing the surface blocks waited 0.4-0.5 s of the pot's
start while the drawing process built its scene.

Its Taichi runs on every core (the simulation's on `--threads`, 1 by default) at a lower priority
(DRAWING_NICENESS): where the simulation waits for frames (the pot's fall and rest) the renderer's
kernels get both cores, and where both processes are busy (Pots' events) the scheduler favours the
simulation (session 42, alternated runs with the MP4: the pot 22.5 -> 25.9 frames/s steady and 8.1 ->
7.4 s in all; Pots the same within the machine's noise). The rasteriser's images do not depend on
the thread count (render/raster.py: keys reduced by atomic max, pixels shaded apart). The same calls
in the same order on the same numbers give the same frames, byte for byte, whatever either process's
thread count (tests/regression/test_draw_process.py draws them here on one thread and there on all).
The drawing process has its own Taichi offline cache (two processes compiling into one cache at once
can crash Taichi 1.7.4: docs/decisions.md) and ignores Ctrl-C (the simulation process ends it after
the last frame). Its errors come back as the exception it raised; if it dies, the error names its exit
status and the end of what it printed.
"""

from __future__ import annotations

import os
import pickle
import queue
import resource
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import traceback
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler
from pathlib import Path

from core.errors import BackendError
from core.heap import freeze_long_lived

ROOT = Path(__file__).resolve().parents[1]
CACHE_SUBDIR = "drawing"  # the drawing process's offline cache, inside the simulation's
HINTS_KIND = "render"  # the project cache's folder (geometry/build_cache.py) of the remembered buffer sizes
STDERR_TAIL = 2000  # characters of the drawing process's output kept in an error
END_WAIT_S = 30.0  # s: how long a drawing process told to stop may take before it is killed
FRAMES_AHEAD = 2  # frames the simulation may step beyond the last one drawn (its frame times stay honest)
DRAWING_NICENESS = 5  # added to the drawing process's nice value: where both processes want a core, the simulation's
ANSWER_WAIT_S = 600.0  # s: the longest wait for an answer (a first frame compiles the renderer, cold: ~1 min)
COMMAND = [sys.executable, "-m", "render.draw_process"]  # the drawing process, given its socket's fd


def draws_apart(renderer: str, draw_process: bool) -> bool:
    """Whether a run's frames are drawn on a drawing process: there are frames to draw, two cores to
    share, and `--draw-here` was not given (draw_process)."""
    from core.host_threads import host_cores

    return renderer != "none" and draw_process and host_cores() >= 2


class DrawingProcessError(BackendError):
    """The drawing process died, stopped answering or failed without an error of its own (the command
    line prints it as one error, as for a missing backend)."""


class SceneFeed:
    """Stands in for the RenderScene that `SceneView` drives: every call becomes a message. Poses and
    particles come as host arrays (`host_side`), read through the stores' own download kernels."""

    host_side = True

    def __init__(self, drawing: DrawingProcess, **scene_args) -> None:
        self._drawing = drawing
        drawing.send("scene", scene_args)

    def update_surfaces(self, blocks: dict, drop=()) -> None:
        self._drawing.send("call", ("update_surfaces", (blocks, list(drop))))

    def make_blocks(self, config: dict) -> None:
        """The bodies' surface blocks are made there (render.surface_blocks.SurfaceBlocks(**config))."""
        self._drawing.send("blocks", config)

    def apply_surface_changes(self, changes) -> None:
        self._drawing.send("changes", changes)

    def set_poses(self, x, q, ref_com) -> None:
        self._drawing.send("call", ("set_poses", (x, q, ref_com)))

    def set_particles(self, x, radius, colors) -> None:
        self._drawing.send("call", ("set_particles", (x, radius, colors)))

    def update(self) -> None:
        self._drawing.send("call", ("update", ()))

    def release(self) -> None:
        """The drawing process releases its scene when it closes."""


class _Sender:
    """Writes messages to the drawing process on a thread of its own, in the order they were put, so
    that the simulation goes on while the drawing process reads (a full socket buffer otherwise blocks
    the writer). A message is pickled when it is put: the caller may change its arrays afterwards."""

    def __init__(self, conn: Connection) -> None:
        self._conn = conn
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self.error: OSError | None = None  # the write that failed (the drawing process ended)
        self._thread = threading.Thread(target=self._write, name="drawing-sender", daemon=True)
        self._thread.start()

    def put(self, message: tuple) -> None:
        self._queue.put(ForkingPickler.dumps(message))  # what Connection.send writes

    def _write(self) -> None:
        while (data := self._queue.get()) is not None:
            if self.error is None:  # after a failed write the rest is dropped
                try:
                    self._conn.send_bytes(data)
                except OSError as exc:
                    self.error = exc

    def stop(self, timeout: float) -> bool:
        """Write what was put, then end the thread; False if it is still writing after `timeout` s."""
        self._queue.put(None)
        self._thread.join(timeout)
        return not self._thread.is_alive()


class DrawingProcess:
    """The simulation's end of a drawing process (module doc)."""

    def __init__(self) -> None:
        """Start the process, which imports Taichi while it waits for `start` (main.py starts it first
        thing, before the simulation's own imports)."""
        mine, theirs = socket.socketpair()
        self._log = tempfile.TemporaryFile()  # what the drawing process prints (kept for an error)
        self._proc = subprocess.Popen([*COMMAND, str(theirs.fileno())], pass_fds=[theirs.fileno()], cwd=ROOT,
                                      stdin=subprocess.DEVNULL, stdout=self._log, stderr=subprocess.STDOUT)
        theirs.close()
        self._conn = Connection(mine.detach())
        self._sender = _Sender(self._conn)
        self.description = None
        self.report: dict = {}
        self.sent = self.drawn = 0  # frames asked for, frames written
        self.idle_work = None  # () -> bool: one piece of work to do while waiting for a frame (False: none left)
        self.failed = False  # its error was raised already

    def start(self, kind: str, width: int, height: int, out: Path, video: str, fps: float, stem: str,
              scene_key: str = "") -> None:
        """What to draw, once this process has started Taichi: renderer, image size, writers, and the
        key under which the drawing process remembers the scene's buffer sizes (render/prewarm.py)."""
        import taichi as ti

        from core.runtime import runtime
        from geometry.build_cache import cache_dir

        rt = runtime()
        cache = Path(ti.lang.impl.current_cfg().offline_cache_file_path) / CACHE_SUBDIR
        hints = cache_dir(HINTS_KIND)  # the project's cache (tests use their own), None where it is off
        ggui = sys.modules.get("render.ggui")  # a Vulkan probe made here already answers for it too
        from core.host_threads import host_cores

        # every core, at a lower priority (module doc): its images do not depend on the thread count
        self.send("start", dict(arch=rt.arch, precision=rt.precision, threads=host_cores(), kind=kind, width=width,
                                height=height, out=str(out), video=video, fps=fps, stem=stem, cache=str(cache),
                                hints=str(hints) if hints is not None else "", scene_key=scene_key,
                                vulkan=ggui.known_vulkan_status() if ggui is not None else None))

    def send(self, what: str, data=None) -> None:
        while self._conn.poll():  # an error it raised meanwhile, or its start
            self._receive()
        if self._sender.error is not None:
            self._died()
        self._sender.put((what, data))

    def _receive(self) -> tuple:
        """The next message; raises the drawing process's error."""
        if not self._conn.poll(ANSWER_WAIT_S):
            self._proc.kill()
            self._died(f"did not answer in {ANSWER_WAIT_S:.0f} s and was stopped")
        try:
            what, data = self._conn.recv()
        except (EOFError, ConnectionResetError):
            self._died()
        if what == "error":
            self.failed = True
            self._proc.wait()
            raise _unpickled(*data)
        if what == "started":
            self.description = data
        elif what == "drawn":
            self.drawn += 1
        return what, data

    def _died(self, how: str = "ended"):
        self.failed = True
        code = self._proc.wait()
        self._log.seek(0)
        tail = self._log.read().decode(errors="replace")[-STDERR_TAIL:]
        raise DrawingProcessError(f"the drawing process {how} (exit status {code}); its output ended with:\n{tail}")

    def started(self) -> str:
        """Wait until the renderer has started; returns its description."""
        while self.description is None:
            self._receive()
        return self.description

    def feed(self, **scene_args) -> SceneFeed:
        return SceneFeed(self, **scene_args)

    def draw(self) -> None:
        """Draw and write a frame of the scene as the calls so far left it; waits while the drawing
        process is more than FRAMES_AHEAD frames behind (a frame's wall time then counts its drawing),
        doing `idle_work` meanwhile where there is some. The first frame waits until it is written: the
        drawing process may still be compiling its renderer, and that wait is the start's, not a later
        frame's (the simulation's first frames are quick now that they step the bodies alone)."""
        self.send("draw")
        self.sent += 1
        while self.sent - self.drawn > (FRAMES_AHEAD if self.drawn else 0):
            if self.idle_work is not None and not self._conn.poll() and self.idle_work():
                continue  # did a piece while the drawing process was busy
            self._receive()

    def close(self) -> dict:
        """Finish the frames sent, close the writers and the process; returns its report
        (first_frame_unix: when the first frame was written; peak_mb: its peak resident memory)."""
        try:
            if not self.failed:  # else its error was raised already: the run ends with what was written
                self.send("close")
                while True:
                    what, data = self._receive()
                    if what == "closed":
                        self.report = data
                        break
        finally:
            self._end()
        return self.report

    def abandon(self) -> None:
        """End the process without its frames (the run failed before it drew one)."""
        self._end()

    def _end(self) -> None:
        if not self._sender.stop(END_WAIT_S):  # a drawing process that reads nothing more: its end
            self._proc.kill()  # fails the blocked write
            self._sender.stop(END_WAIT_S)
        self._conn.close()  # the drawing process reads the end of its input and stops
        try:
            self._proc.wait(timeout=END_WAIT_S)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._log.close()


def _pickled(exc: BaseException) -> tuple[bytes | None, str]:
    """An exception as (pickle, or None where it does not pickle; its traceback as text)."""
    text = "".join(traceback.format_exception(exc))
    try:
        data = pickle.dumps(exc)
        pickle.loads(data)
    except Exception:
        data = None
    return data, text


def _unpickled(data: bytes | None, text: str) -> BaseException:
    return pickle.loads(data) if data is not None else DrawingProcessError(f"the drawing process failed:\n{text}")


class _Drawer:
    """The drawing process's side: a RenderScene, the renderer, the camera and the writers."""

    def __init__(self, start: dict) -> None:
        from core.runtime import init_taichi
        from render.select import make_renderer

        os.environ["TI_OFFLINE_CACHE_FILE_PATH"] = start["cache"]  # its own (module doc), read by ti.init
        if hasattr(os, "nice"):
            os.nice(DRAWING_NICENESS)  # the simulation first where both want a core (module doc)
        init_taichi(start["arch"], start["precision"], start["threads"])
        if start["vulkan"] is not None:
            from render.ggui import assume_vulkan_status

            assume_vulkan_status(start["vulkan"])
        self.renderer = make_renderer(start["kind"], start["width"], start["height"])
        self.start = start
        self.frames = self.video = self.writing = None  # made once the World is built (a failed build writes nothing)
        self.scene = self.blocks = None
        self.framing = None

    def handle(self, what: str, data) -> str | None:
        """One message; returns "drawn" once a frame is written."""
        from render.prewarm import remember
        from render.scene_data import RenderScene
        from render.surface_blocks import SurfaceBlocks

        if what == "scene":
            if self.start["hints"]:
                remember(Path(self.start["hints"]), self.start["scene_key"], data)
            self.scene = RenderScene(**data)
        elif what == "blocks":
            self.blocks = SurfaceBlocks(**data)
        elif what == "changes":
            self.blocks.apply(data, self.scene)
        elif what == "camera":
            self.framing = data
        elif what == "call":
            name, args = data
            getattr(self.scene, name)(*args)
        elif what == "warm":
            self._open_writers()
            self.renderer.render(self.scene, self.framing.camera)  # compiles; the camera does not move
        elif what == "draw":
            self._open_writers()
            self.framing.update(*self.scene.body_bounds())
            self.writing.submit(self.renderer.render(self.scene, self.framing.camera))
            return "drawn"
        else:
            raise AssertionError(f"unknown message {what!r}")

    def prewarm(self) -> None:
        """Compile the renderer for the buffer sizes this scene asked for last time (render/prewarm.py)."""
        from render.prewarm import prewarm, remembered

        sizes = remembered(Path(self.start["hints"]), self.start["scene_key"]) if self.start["hints"] else None
        if sizes is not None:
            prewarm(self.renderer, sizes)

    def _open_writers(self) -> None:
        from render.writers import PngSequenceWriter, WritingThread, make_writer

        if self.frames is None:
            out = Path(self.start["out"])
            self.frames = PngSequenceWriter(out / "frames")
            self.video = make_writer(self.start["video"], out, fps=self.start["fps"], stem=self.start["stem"])
            self.writing = WritingThread([self.frames, self.video])

    def close(self) -> dict:
        first = None
        if self.writing is not None:
            self.writing.close()  # every frame submitted is written (or its writer's error raised)
            first = self.writing.first_written_unix
        if self.video is not None:
            self.video.close()
        if self.frames is not None:
            self.frames.close()
        self.renderer.release()
        if self.scene is not None:
            self.scene.release()
        return dict(first_frame_unix=first, peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)


def serve(fd: int) -> int:
    """The drawing process's loop: messages until 'close' (or the simulation's end of the socket)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the simulation's to handle
    conn = Connection(fd)
    drawer = None
    try:
        if not conn.poll():  # until the simulation has started Taichi and says what to draw
            from core.taichi_frontend import install_before_import

            install_before_import()
            import taichi  # noqa: F401
        while True:
            try:
                what, data = conn.recv()
            except EOFError:  # the simulation ended without closing: nothing more to draw
                if drawer is not None and drawer.writing is not None:
                    drawer.writing.close()  # the frames drawn are written whole (no temporary left)
                return 0
            if what == "start":
                drawer = _Drawer(data)
                conn.send(("started", drawer.renderer.message))
                drawer.prewarm()  # while the World builds
                freeze_long_lived()  # its imports and renderer: no collection walks them again (core/heap.py)
            elif what == "close":
                conn.send(("closed", drawer.close()))
                return 0
            elif drawer.handle(what, data) == "drawn":
                conn.send(("drawn", None))
    except BaseException as exc:  # noqa: BLE001 - every error goes back to the simulation
        try:
            conn.send(("error", _pickled(exc)))
        except OSError:
            pass
        return 1


if __name__ == "__main__":
    sys.exit(serve(int(sys.argv[1])))
