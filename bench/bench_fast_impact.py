"""Frame cost of a hard blow: the pot thrown at the floor at 10, 50 and 200 m/s (issue 16, "a pot at
200 m/s": its pieces fly off together, and the contacts between them must stay few).

    .venv/bin/python bench/bench_fast_impact.py [--frames N] [--speeds 10,50,200]

The pot scene with the pot 3 mm above the floor (tests/stability/test_impacts.py's case) and a
downward velocity; N frames (default 6) from the blow, each timed as a whole (rigid steps with their
travel splits, the fracture event, debris). Reported per speed: the fracture pieces, the most
contacts in one rigid step, the first frame (the blow and its event) and the slowest later frame in
ms, beside the paper's Table 2 average frame rate for the Pot (10.2 fps: 98 ms a frame).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

POT_LOW = "objects.pot.position=[0,0.0696,0]"  # lowest tet vertex 3 mm above the floor
PAPER_POT_FPS = 10.2  # Table 2, Pot: average frame rate (Xeon W3530 + GTX 760)


def run_speed(speed: float, frames: int) -> dict:
    """The pot at `speed` m/s onto the floor: pieces, most contacts in a step, frame times (ms)."""
    from anisofrac import api

    sim = api.load("pot", [POT_LOW, f"objects.pot.velocity=[0,-{speed},0]"])
    rigid = sim.world.rigid
    most = 0
    inner = rigid.step

    def counted_step(dt, split=True, free=False):
        nonlocal most
        inner(dt, split, free)
        most = max(most, rigid._nc)

    rigid.step = counted_step
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        sim.step(1)
        times.append((time.perf_counter() - t0) * 1e3)
    pieces = sim.pieces()["total"]
    sim.close()
    return dict(speed=speed, pieces=pieces, contacts=most, first=times[0], later=max(times[1:], default=0.0))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=6, help="frames from the blow (default 6, at least 2)")
    ap.add_argument("--speeds", default="10,50,200", help="comma-separated speeds in m/s (0 < v <= 200)")
    args = ap.parse_args(argv)
    if args.frames < 2:
        ap.error(f"--frames {args.frames}: allowed >= 2")
    try:
        speeds = [float(s) for s in args.speeds.split(",")]
    except ValueError:
        ap.error(f"--speeds {args.speeds!r}: allowed comma-separated numbers")
    if not all(0.0 < s <= 200.0 for s in speeds):
        ap.error(f"--speeds {args.speeds!r}: each in (0, 200] m/s (the solver's speed clamp)")
    from anisofrac import api

    api.init("cpu", "f32", threads=1)
    run_speed(speeds[0], 2)  # compiles what a blow launches: not timed
    print(f"The pot thrown at the floor, {args.frames} frames from the blow (CPU, one thread, f32); "
          f"paper Table 2: {PAPER_POT_FPS} fps = {1e3 / PAPER_POT_FPS:.0f} ms a frame")
    print(f"{'m/s':>6} {'pieces':>7} {'contacts':>9} {'blow ms':>9} {'later max ms':>13}")
    for speed in speeds:
        r = run_speed(speed, args.frames)
        print(f"{r['speed']:6.0f} {r['pieces']:7d} {r['contacts']:9d} {r['first']:9.1f} {r['later']:13.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
