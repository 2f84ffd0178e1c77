"""Simulation vs rendering per frame, for each paper scene (issue 15, "Speed"; DESIGN.md section 8).

    .venv/bin/python bench/bench_frames.py [--quick] [--scenes pot,glass_r3] [--width 1280 --height 720] [--readme]

Each scene runs headless as `main.py run` does (studio look: shadow map, highlights, edge filter;
the following camera) over a window from frame 0 to its first fracture event plus AFTER_EVENT frames
(at most MAX_FRAMES). Per frame it times `World.step_frame` (simulation) and the frame (surfaces
refreshed when fracture changed them, camera, rasteriser; no PNG encoding). Reported: medians per
frame, and means after frame 0 (which compiles everything; later compile spikes, when a buffer
grows, do count: a user waits for them); the render / simulation ratio of the means against the target
(< 1/4 for Pots at 1280x720); frames per second with and without rendering beside the paper's
Table 2 average frame rate (Xeon W3530 + GTX 760; which counts no rendering). `--readme` runs
README_SCENES at 1280x720 and writes the README's frame-cost table (the means) between its markers.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.study_common import clock, md_table  # noqa: E402

AFTER_EVENT = 30  # frames measured after the first fracture event (pieces falling, breaking again)
MAX_FRAMES = 60  # bound of the window
TARGET_RATIO = 0.25  # render time / simulation time per frame the issue asks for (Pots, 1280x720)
PAPER_FPS = {"pot": 10.2, "pot_basic": 10.2, "glass_r3": 36.8, "glass_r5": 36.8, "pots": 1.3, "pet": 1.2,
             "taichi": 7.6}  # paper Table 2, average frame rate
SCENES = ("pot", "glass_r3", "glass_r5", "taichi", "pet", "pots")
QUICK_SCENES = ("pot", "glass_r3")
README_SCENES = ("pot", "glass_r3", "taichi", "pots")  # the README's frame-cost table
README_BEGIN = "<!-- bench_frames: begin -->"
README_END = "<!-- bench_frames: end -->"


def measure(name: str, width: int, height: int, max_frames: int) -> dict:
    from render.session import HeadlessSession
    from scenes.loader import load_scene
    from sim.world import World

    world = World(load_scene(name))
    session = HeadlessSession(world, "raster", width, height)
    sim, ren = [], []
    end = max_frames
    try:
        for f in range(max_frames):
            t0 = clock()
            world.step_frame()
            t1 = clock()
            session.draw()
            t2 = clock()
            sim.append(t1 - t0)
            ren.append(t2 - t1)
            if world.events and end == max_frames:
                end = min(max_frames, world.events[0]["frame"] + 1 + AFTER_EVENT)
            if f + 1 >= end:
                break
        tris = session.view.scene.n_tris
    finally:
        session.close()
        world.release()
    s, r = statistics.median(sim), statistics.median(ren)
    sm, rm = statistics.fmean(sim[1:] or sim), statistics.fmean(ren[1:] or ren)  # frame 0 compiles
    return dict(scene=name, frames=len(sim), triangles=tris, sim_ms=1e3 * s, render_ms=1e3 * r, sim_mean_ms=1e3 * sm,
                render_mean_ms=1e3 * rm, ratio=rm / sm, fps_sim=1.0 / sm, fps_both=1.0 / (sm + rm))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK_SCENES)}, 640x480")
    ap.add_argument("--scenes", default=None, help="comma-separated scene names")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--threads", type=int, default=1, help="CPU threads (the run's default is 1)")
    ap.add_argument("--readme", action="store_true",
                    help=f"run {', '.join(README_SCENES)} at 1280x720 and write the README's frame-cost table")
    args = ap.parse_args(argv)
    if args.readme and (args.quick or args.scenes or (args.width, args.height) != (1280, 720) or args.threads != 1):
        ap.error("--readme measures the README's scenes at 1280x720 with one thread: give no other option")
    from core.runtime import init_taichi, runtime

    init_taichi("cpu", threads=args.threads)
    names = args.scenes.split(",") if args.scenes else (
        README_SCENES if args.readme else QUICK_SCENES if args.quick else SCENES)
    width, height = (640, 480) if args.quick else (args.width, args.height)
    rows, means = [], []
    for name in names:
        m = measure(name, width, height, MAX_FRAMES)
        means.append(m)
        rows.append([m["scene"], m["frames"], f"{m['triangles']:,}", f"{m['sim_ms']:.1f}", f"{m['render_ms']:.1f}",
                     f"{m['sim_mean_ms']:.1f}", f"{m['render_mean_ms']:.1f}", f"{m['ratio']:.2f}",
                     f"{m['fps_sim']:.2f}", f"{m['fps_both']:.2f}", PAPER_FPS.get(name, "")])
        print(f"{name}: sim {m['sim_ms']:.1f} ms, render {m['render_ms']:.1f} ms per frame", file=sys.stderr)
    print(f"Simulation vs rendering per frame, {width}x{height}, CPU ({runtime().device}, "
          f"{args.threads} thread(s)); per frame: medians, and means after frame 0 (which compiles); "
          f"target: mean render / mean simulation < {TARGET_RATIO} (Pots)\n")
    print(md_table(["scene", "frames", "triangles drawn", "sim median ms", "render median ms", "sim mean ms",
                    "render mean ms", "render / sim (means)", "fps sim only", "fps with frames",
                    "paper fps (Table 2)"], rows))
    if args.readme:
        from bench.bench_scenes import write_readme

        write_readme(readme_table(means), begin=README_BEGIN, end=README_END)
    return 0


def readme_table(measured: list[dict]) -> str:
    """The README's frame-cost table: mean simulation and rendering ms per frame (after frame 0) and
    their ratio, one row per measured scene (`measure`'s dicts)."""
    return md_table(["scene", "simulation ms", "rendering ms", "render / sim"],
                    [[m["scene"], f"{m['sim_mean_ms']:.1f}", f"{m['render_mean_ms']:.1f}", f"{m['ratio']:.2f}"]
                     for m in measured])


if __name__ == "__main__":
    raise SystemExit(main())
