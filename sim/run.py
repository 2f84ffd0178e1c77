"""A headless run: build the World, step it, write frames, video and stats.json (DESIGN.md section 7).

Outputs in the run folder: `frames/frame_00000.png` ... (when a renderer is used), `<scene>.mp4` or
`.gif`, `stats.json` (Table 1 counts, Table 2 timings per fracture event, average frame rate,
per-frame stage times, the scene and versions used) and, on request, fragment meshes per frame
(`meshes/frame_00000.obj|ply`) and a VTU series of the particles (`vtu/`, meshio, for ParaView).
Every file goes to a temporary name first, so an interrupted run leaves each finished file readable.
"""

from __future__ import annotations

import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.output import atomic_write_json, prepare_output_dir, remove_frame_sequences
from core.runtime import runtime
from scenes.config import SceneConfig
from sim.guards import state_hash

STATS_VERSION = 1


SETTLED_S = 1.0  # s: a run ends once every body has been asleep (and the debris at rest) this long


class SettleClock:
    """Counts the consecutive frames in which nothing moved (World.settled); `tick(world)` is True
    once that has lasted SETTLED_S."""

    def __init__(self, fps: float) -> None:
        self.needed = max(1, round(SETTLED_S * fps))
        self.frames = 0

    def tick(self, world) -> bool:
        self.frames = self.frames + 1 if world.settled() else 0
        return self.frames >= self.needed


@dataclass
class RunOptions:
    out: Path
    frames: int | None = None  # None: the scene's own frame count
    renderer: str = "auto"  # ggui | raster | auto | none
    video: str = "mp4"  # mp4 | gif | none
    width: int = 640
    height: int = 480
    overwrite: bool = False
    meshes: str = "none"  # none | obj | ply: fragment meshes every frame
    vtu: bool = False  # particle VTU series
    export: tuple = ()  # animated exports of the whole run: "glb" (animation.glb), "usd" (animation.usd)
    progress: bool = True
    until_settled: bool = True  # stop once nothing has moved for SETTLED_S (False: every frame)
    colors: str = "material"  # material: each material's look | fragments: a colour per fragment
    crack_lines: bool = True  # draw where crack faces meet the outer surface (render/crack_lines.py)
    draw_process: bool = True  # draw on a second process while the next frame steps (render/draw_process.py)


def versions() -> dict:
    import scipy
    import taichi

    return dict(python=platform.python_version(), taichi=".".join(map(str, taichi.__version__)),
                numpy=np.__version__, scipy=scipy.__version__, platform=platform.platform())


def _without_timings(obj):
    """A copy of `obj` without the keys that hold wall-clock times (names ending in `_ms`)."""
    if isinstance(obj, dict):
        return {k: _without_timings(v) for k, v in obj.items() if not k.endswith("_ms")}
    if isinstance(obj, list):
        return [_without_timings(v) for v in obj]
    return obj


def collect_stats(world, wall_seconds: float, frames_done: int, interrupted: bool = False,
                  frame_wall_ms: list[float] | None = None, first_frame_unix: float | None = None) -> dict:
    """stats.json: everything but the `timings` section is reproducible for a given scene and seed."""
    rt = runtime()
    counts = world.counts()
    events = _without_timings(world.events)
    event_times = [{k: v for k, v in e.items() if k.endswith("_ms")} for e in world.events]
    cfg: SceneConfig = world.cfg
    return {
        "stats_version": STATS_VERSION,
        "scene": cfg.scene.name,
        "scene_file": cfg.source,
        "description": cfg.scene.description,
        "effects": cfg.scene.effects,
        "stages": world.stages,
        "seed": world.seed,
        "frames": frames_done,
        "interrupted": interrupted,
        "runtime": dict(arch=rt.arch, precision=rt.precision, threads=rt.threads),
        "table1": counts,
        "events": events,
        "mass": world.mass_balance(),
        "state_hash": state_hash(world),
        "timings": {
            "device": rt.device,
            "versions": versions(),
            "build_s": round(world.build_seconds, 4),
            "wall_s": round(wall_seconds, 4),
            "average_fps": round(frames_done / wall_seconds, 3) if wall_seconds > 0 else None,
            "table2_events": event_times,
            "stage_totals_ms": {k: round(v * 1e3, 3) for k, v in world.timers.total.items()},
            "per_frame_ms": world.timers.frames,
            # wall time of each whole frame as `main.py run` does it (simulation, drawing, exports)
            "frame_wall_ms": [round(t, 3) for t in frame_wall_ms or []],
            "first_frame_unix": first_frame_unix,  # time.time() when the first frame was done
        },
    }


EXPORT_FILES = {"glb": "animation.glb", "usd": "animation.usd"}  # --export kind -> file in the output folder


def write_animation(recorder, out: Path, kinds) -> list[str]:
    """Write the recorded run in each requested format; returns the file names written."""
    from sim.export_gltf import write_glb
    from sim.export_usd import write_usd

    writers = {"glb": write_glb, "usd": write_usd}
    for kind in kinds:
        writers[kind](recorder, out / EXPORT_FILES[kind])
    return [EXPORT_FILES[k] for k in kinds]


@dataclass
class RunStart:
    """What a run sets up before its World: the output folder, ready, and the drawing process (None
    where frames are drawn in this process), started first so that it starts while the World builds."""

    out: Path
    drawing: object = None  # render.draw_process.DrawingProcess
    made_out: bool = False  # the output folder did not exist before

    def abandon(self) -> None:
        """The run failed before its first frame: end the drawing process, and remove the output
        folder again where this run made it and nothing was written (a rerun needs no --overwrite)."""
        if self.drawing is not None:
            self.drawing.abandon()
        if self.made_out and self.out.is_dir() and not any(self.out.iterdir()):
            self.out.rmdir()


def start_run(cfg: SceneConfig, opts: RunOptions, drawing=None) -> RunStart:
    """Prepare the output folder and start the drawing process where `draws_apart`: a second process
    draws and writes the frames while this one steps the next. `drawing`: a DrawingProcess started
    already (main.py starts it first thing), told here what to draw."""
    made = not Path(opts.out).exists()
    try:
        out = prepare_output_dir(opts.out, opts.overwrite)
        if opts.overwrite:
            remove_frame_sequences(out)  # a shorter run must not leave an earlier one's frames behind
        from render.draw_process import DrawingProcess, draws_apart

        if not draws_apart(opts.renderer, opts.draw_process):
            if drawing is not None:
                drawing.abandon()
            return RunStart(out, made_out=made)
        drawing = drawing or DrawingProcess()
        drawing.start(opts.renderer, opts.width, opts.height, out, opts.video, cfg.scene.fps, cfg.scene.name,
                      scene_key(cfg, opts))
    except BaseException:
        if drawing is not None:
            drawing.abandon()
        raise
    return RunStart(out, drawing, made)


def scene_key(cfg: SceneConfig, opts: RunOptions) -> str:
    """What a scene's render buffers depend on, as a short digest (render/prewarm.py): the scene's
    content, not where its file lies (a clone elsewhere finds the sizes its scene asked for)."""
    import dataclasses
    import hashlib

    content = dataclasses.replace(cfg, source="")
    return hashlib.sha256(f"{content!r} {opts.renderer} {opts.width}x{opts.height}".encode()).hexdigest()[:32]


def _world_and_frames(cfg: SceneConfig, opts: RunOptions, world, start: RunStart):
    """The World (built here when `world` is None) and the HeadlessSession that draws its frames (None
    without a renderer); on an error, what was made is released and the drawing process ended."""
    from sim.world import World

    own, renderer = world is None, None
    try:
        world = World(cfg) if own else world
        if opts.renderer != "none":
            from render.session import HeadlessSession

            renderer = HeadlessSession(world, opts.renderer, opts.width, opts.height, start.out, opts.video,
                                       opts.colors, opts.crack_lines, drawing=start.drawing)
            print(renderer.description, file=sys.stderr)
        if start.drawing is not None and world.warm_up is not None:
            # event kernels compile while the simulation waits for the drawing process (sim/warm_up.py)
            start.drawing.idle_work = world.warm_up.run_one
            world.warm_up.idle = True
    except BaseException:
        start.abandon()
        if own and world is not None:
            world.release()
        raise
    return world, renderer


def run(cfg: SceneConfig, opts: RunOptions, world=None, start: RunStart | None = None) -> dict:
    """Run a scene headless; returns the stats written to stats.json. With `world` (a built World of
    `cfg`, e.g. the Python API's Simulation.world) that world runs on from where it is and stays
    allocated; without, a World is built and released at the end. `start`: `start_run`'s, made before
    the World was built (else made here)."""
    from tqdm import tqdm

    start = start or start_run(cfg, opts)
    out, drawing = start.out, start.drawing
    frames = opts.frames or cfg.scene.frames
    own = world is None
    world, renderer = _world_and_frames(cfg, opts, world, start)
    t0 = time.perf_counter()
    done = 0
    interrupted = False
    bar = tqdm(total=frames, desc=cfg.scene.name, unit="frame", disable=not opts.progress, file=sys.stderr)
    settle = SettleClock(cfg.scene.fps)
    stopped = None
    recorder = None
    if opts.export:
        from sim.animation import AnimationRecorder

        recorder = AnimationRecorder(world, cfg.scene.fps)
        recorder.record(world, 0)
    frame_wall_ms: list[float] = []
    first_frame_unix = None
    try:
        for _ in range(frames):
            t_frame = time.perf_counter()
            world.step_frame()
            done += 1
            if renderer is not None:
                renderer.write_frame()
            if recorder is not None:
                recorder.record(world, done)
            if opts.meshes != "none" or opts.vtu:
                from sim.export_frames import write_frame_exports

                write_frame_exports(world, out, done - 1, opts.meshes, opts.vtu)
            frame_wall_ms.append((time.perf_counter() - t_frame) * 1e3)
            if first_frame_unix is None and drawing is None:
                first_frame_unix = time.time()
            if opts.progress:  # the count is a kernel over the store once it changed (2 ms a frame in Pots)
                bar.set_postfix(fragments=world.fragment_count(), events=len(world.events))
            bar.update(1)
            if opts.until_settled and settle.tick(world):
                stopped = f"settled: nothing moved for {SETTLED_S:g} s"
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
        if renderer is not None:
            renderer.close()
            first_frame_unix = renderer.report.get("first_frame_unix", first_frame_unix)
        if world.warm_up is not None:
            world.warm_up.idle = False  # a World stepped on after the run (the API's) has no waits to use
        wall = time.perf_counter() - t0  # the drawing process's last frames included
        stats = collect_stats(world, wall, done, interrupted, frame_wall_ms, first_frame_unix)
        if renderer is not None and renderer.report:
            stats["timings"]["drawing_peak_mb"] = round(renderer.report["peak_mb"], 1)
        stats["stopped"] = stopped
        if recorder is not None:
            stats["exports"] = write_animation(recorder, out, opts.export)
        atomic_write_json(out / "stats.json", stats)
        if own:
            world.release()
    if interrupted:
        raise KeyboardInterrupt
    return stats
