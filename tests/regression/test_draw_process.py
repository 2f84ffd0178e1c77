"""Frames drawn on a second process (render/draw_process.py) are the frames drawn in the simulation's
own process, byte for byte, through a fracture event, its debris and the surfaces it changed; the
drawing process's errors reach the caller as the error it raised, and its death as an error that
names its exit status."""

from __future__ import annotations

import json
import os
import sys
import uuid

import pytest

from core.errors import ConfigError
from render.draw_process import DrawingProcess, DrawingProcessError
from scenes.loader import load_scene
from sim.run import RunOptions, run

FRAMES = 8  # glass_r3: the ball breaks the pane within 6 frames and throws debris


def test_the_drawing_process_draws_the_frames_drawn_in_process(tmp_path):
    """The drawing process draws on every core (render/draw_process.py), this process on the test's one
    thread: the same bytes, so the frames do not depend on the thread count either."""
    cfg = load_scene("glass_r3")
    stats = {}
    for mode, separate in (("process", True), ("here", False)):
        stats[mode] = run(cfg, RunOptions(out=tmp_path / mode, frames=FRAMES, renderer="raster", video="gif",
                                          width=96, height=72, progress=False, draw_process=separate))
    assert stats["process"]["events"] and stats["process"]["table1"]["pieces"]["debris"] > 0
    assert stats["process"]["state_hash"] == stats["here"]["state_hash"]
    for k in range(FRAMES):
        name = f"frames/frame_{k:05d}.png"
        assert (tmp_path / "process" / name).read_bytes() == (tmp_path / "here" / name).read_bytes(), name
    assert (tmp_path / "process" / "glass_r3.gif").read_bytes() == (tmp_path / "here" / "glass_r3.gif").read_bytes()
    timings = json.loads((tmp_path / "process" / "stats.json").read_text())["timings"]
    assert timings["first_frame_unix"] > 0 and timings["drawing_peak_mb"] > 0


def test_an_error_in_the_drawing_process_reaches_the_caller(tmp_path):
    with pytest.raises(ConfigError, match="render.size"):
        run(load_scene("tet_cut_31"), RunOptions(out=tmp_path / "t", frames=2, renderer="raster", video="none",
                                                 width=0, height=48, progress=False))
    assert not (tmp_path / "t" / "stats.json").exists()


def test_a_drawing_process_that_dies_is_named(tmp_path):
    drawing = DrawingProcess()
    drawing.start("raster", 32, 24, tmp_path, "none", 30.0, "t")
    assert "raster" in drawing.started()
    drawing._proc.kill()
    drawing._proc.wait()
    with pytest.raises(DrawingProcessError, match="exit status -9"):
        for _ in range(100):  # the first sends may still fit in the socket's buffer
            drawing.draw()
        drawing.close()
    drawing.abandon()


def test_a_run_that_fails_before_its_first_frame_leaves_no_folder(tmp_path, monkeypatch):
    """The drawing process starts before the World builds; a build that fails ends it and removes the
    output folder the run made (a rerun needs no --overwrite), as when frames are drawn here."""
    import sim.world

    def broken(self, cfg, *args, **kwargs):
        raise ConfigError("objects[0].mesh", "broken.obj", "a closed surface (test)")

    monkeypatch.setattr(sim.world.World, "__init__", broken)
    for separate in (True, False):
        out = tmp_path / f"t{separate}"
        with pytest.raises(ConfigError, match="broken.obj"):
            run(load_scene("tet_cut_31"), RunOptions(out=out, frames=2, renderer="raster", video="gif", width=32,
                                                     height=24, progress=False, draw_process=separate))
        assert not out.exists()


SPY = """
import json, os, sys
import taichi.lang.kernel_impl as kernel_impl
import render.draw_process as draw_process

compiled, phase = [], ["start"]
materialize = kernel_impl.Kernel.materialize

def spy(self, key=None, args=None, arg_features=None):
    if key is None or key not in self.compiled_kernels:
        compiled.append((phase[0], self.func.__qualname__))
    return materialize(self, key, args, arg_features)

kernel_impl.Kernel.materialize = spy
handle = draw_process._Drawer.handle

def handled(self, what, data):
    if what == "scene":
        phase[0] = "scene"
    out = handle(self, what, data)
    if out == "drawn":
        phase[0] = "later"
    return out

draw_process._Drawer.handle = handled
code = draw_process.serve(int(sys.argv[1]))
with open(os.environ["SPY_OUT"], "w") as f:
    json.dump(compiled, f)
sys.exit(code)
"""


def test_the_drawing_process_compiles_nothing_after_its_first_frame(tmp_path, monkeypatch):
    """Issue 16 item 2 for the drawing process: its kernels compile by its first frame (the warm-up
    render while the simulation steps); glass_r3's event, changed surfaces and debris come later."""
    import render.draw_process as draw_process

    monkeypatch.setattr(draw_process, "COMMAND", [sys.executable, "-c", SPY])
    monkeypatch.setenv("SPY_OUT", str(tmp_path / "compiled.json"))
    stats = run(load_scene("glass_r3"), RunOptions(out=tmp_path / "g", frames=FRAMES, renderer="raster", video="none",
                                                   width=96, height=72, progress=False))
    assert stats["events"] and stats["table1"]["pieces"]["debris"] > 0
    compiled = json.loads((tmp_path / "compiled.json").read_text())
    assert any(phase == "start" for phase, _ in compiled)  # the spy sees compiles
    late = [name for phase, name in compiled if phase == "later"]
    assert late == [], late


def test_a_scene_drawn_before_compiles_its_first_frame_while_the_world_builds(tmp_path, monkeypatch):
    """render/prewarm.py: the first run of a scene remembers its buffer sizes, and the next run's
    drawing process compiles its renderer for them before the scene comes: from the scene on, its
    first frame compiles nothing. The first run, with nothing remembered, compiles there."""
    import render.draw_process as draw_process
    import sim.run

    monkeypatch.setattr(draw_process, "COMMAND", [sys.executable, "-c", SPY])
    key = f"test-{uuid.uuid4().hex}"  # nothing remembered under it yet
    monkeypatch.setattr(sim.run, "scene_key", lambda cfg, opts: key)
    at_scene = []
    for k in range(2):
        monkeypatch.setenv("SPY_OUT", str(tmp_path / f"compiled{k}.json"))
        run(load_scene("pot"), RunOptions(out=tmp_path / f"p{k}", frames=2, renderer="raster", video="none",
                                          width=96, height=72, progress=False))
        compiled = json.loads((tmp_path / f"compiled{k}.json").read_text())
        at_scene.append([name for phase, name in compiled if phase == "scene"])
    assert "_k_cover" in at_scene[0]  # the spy sees the first frame's compiles
    assert at_scene[1] == [], at_scene[1]
    # remembered in the project's cache, which the test suite keeps apart from the user's (conftest.py)
    from geometry.build_cache import CACHE_ENV, cache_dir
    from render.draw_process import HINTS_KIND
    from render.prewarm import HINTS_FILE

    hints = cache_dir(HINTS_KIND) / HINTS_FILE
    assert key in json.loads(hints.read_text()) and hints.is_relative_to(os.environ[CACHE_ENV])
