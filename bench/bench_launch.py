"""Kernel launch cost on the CPU backend: loops through Taichi's thread pool against serial loops.

    .venv/bin/python bench/bench_launch.py [--frames N]

Taichi 1.7.4 runs every offloaded parallel loop of a CPU kernel through its thread pool, and the
launching thread sleeps until the pool is done, also with one thread. Single-thread runs build the
outermost range loops serial instead (core/taichi_frontend.py, `install_serial_loops`). Each build
is measured in its own process (the setting holds for a whole process): "pooled" is Taichi as it
comes, "serial" is what `core.runtime.init_taichi(threads=1)` gives.

Table 1: microseconds per launch of a kernel with 0, 1 and 5 range loops over 4 items (the loops'
work is nil: this is the launch cost alone), median of 5 x 400 launches.
Table 2: the pot scene (6.5k particles) stepped over frames 2 to 2 + N before its impact (one body
falling, nothing to collide with: the frame is launch-bound) and its first N frames after frame
2 + N; milliseconds per frame, beside the paper's Table 2 average frame rate for the Pot (10.2 fps,
98 ms per frame) and the state hash at the end (equal: the builds simulate the same thing).
"""


import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PAPER_POT_FPS = 10.2  # Table 2, Pot: average frame rate (Xeon W3530 + GTX 760)
LAUNCHES = 400  # per timing
REPEATS = 5  # timings per kernel (median)


def _measure(mode: str, frames: int) -> dict:
    """In this process: Taichi on the CPU with one thread, pooled or serial loops; the two tables."""
    import taichi as ti

    import core.taichi_frontend as frontend
    from anisofrac import api

    if mode == "pooled":
        frontend.install_serial_loops = lambda: None  # Taichi's own build: every loop through the pool
    api.init("cpu", "f32", threads=1)
    data = ti.field(ti.f32, shape=4)

    @ti.kernel
    def no_loop():
        data[0] += 1.0

    @ti.kernel
    def one_loop(n: ti.i32):
        for i in range(n):
            data[i] += 1.0

    @ti.kernel
    def five_loops(n: ti.i32):
        for i in range(n):
            data[i] += 1.0
        for i in range(n):
            data[i] *= 0.5
        for i in range(n):
            data[i] += 1.0
        for i in range(n):
            data[i] *= 0.5
        for i in range(n):
            data[i] += 1.0

    launch = {}
    for name, call in (("0 loops", no_loop), ("1 loop", lambda: one_loop(4)), ("5 loops", lambda: five_loops(4))):
        call()
        laps = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            for _ in range(LAUNCHES):
                call()
            laps.append((time.perf_counter() - t0) / LAUNCHES * 1e6)
        launch[name] = statistics.median(laps)
    from sim.guards import state_hash

    sim = api.load("pot")
    sim.step(2)
    t0 = time.perf_counter()
    sim.step(frames)
    falling = (time.perf_counter() - t0) / frames * 1e3
    t0 = time.perf_counter()
    sim.step(frames)
    after = (time.perf_counter() - t0) / frames * 1e3
    return dict(launch=launch, falling_ms=falling, after_ms=after, hash=state_hash(sim.world)[:12])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=12, help="frames per pot window (default 12)")
    ap.add_argument("--child", choices=("pooled", "serial"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.frames < 1:
        ap.error(f"--frames {args.frames}: allowed >= 1")
    if args.child:
        print(json.dumps(_measure(args.child, args.frames)))
        return 0
    rows = {}
    for mode in ("pooled", "serial"):
        out = subprocess.run([sys.executable, __file__, "--child", mode, "--frames", str(args.frames)],
                             capture_output=True, text=True, check=True, cwd=ROOT)
        rows[mode] = json.loads(out.stdout.strip().splitlines()[-1])
    print("Table 1: microseconds per kernel launch (CPU, one thread, loops over 4 items)")
    print(f"{'kernel':>10} {'pooled':>9} {'serial':>9}")
    for name in rows["pooled"]["launch"]:
        print(f"{name:>10} {rows['pooled']['launch'][name]:9.1f} {rows['serial']['launch'][name]:9.1f}")
    paper_ms = 1e3 / PAPER_POT_FPS
    print(f"\nTable 2: pot, ms per frame (paper Table 2: {PAPER_POT_FPS} fps = {paper_ms:.0f} ms per frame)")
    print(f"{'build':>8} {'falling':>9} {'impact+':>9} {'state hash':>14}")
    for mode, r in rows.items():
        print(f"{mode:>8} {r['falling_ms']:9.1f} {r['after_ms']:9.1f} {r['hash']:>14}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
