"""Benchmark: the cost of one fracture event against the size of the scene (issue 16, item 3).

Usage: .venv/bin/python bench/bench_event_scale.py [--counts 1,4,13] [--repeat 3]

The same blow on the same pot (the `pot` scene's porcelain pot, 6.5k particles, struck on its
side by a rigid anvil at 3.2 m/s, the speed of its 0.6 m drop) in scenes holding 1, 4 and 13 such
pots (the Pots scene's count), side by side and at rest (gravity off): an event that touched only
the struck body and the particles near its cracks would cost the same in all three. Printed per
scene size: particles in the scene, the whole event (analysis to split, as a user waits) and the
paper's Table 2 columns (stress analysis, particle subdivision, crack generation), best of
--repeat fresh scenes. A warm-up strike in a separate one-pot scene comes first, so no column pays
for a first use in the process.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

STRIKE_SPEED = 3.2  # m/s: the pot scene's drop of 0.6 m (v = sqrt(2 g h))
SPACING = 0.3  # m: between neighbouring pots (a pot is 0.18 m wide)
COLUMNS = ("whole_event_ms", "stress_analysis_ms", "particle_subdivision_ms", "crack_generation_ms")


def pots_scene(count: int):
    """The pot scene with `count` pots side by side along x, at rest, gravity off (Simulation)."""
    import anisofrac

    return anisofrac.load("pot", [f"objects.pot.count={count}", f"objects.pot.spacing=[{SPACING},0.0,0.0]",
                                  "scene.gravity=[0.0,0.0,0.0]"])


def strike_first_pot(sim) -> dict:
    """The event record of the blow on pot 0 (a downward anvil on the point it would land on)."""
    point = sim.surface_point(0, (0.0, -1.0, 0.0))
    record = sim.strike(0, point, (0.0, -STRIKE_SPEED, 0.0))
    if record is None:
        raise RuntimeError("the strike broke nothing: the benchmark's event did not happen")
    return record


def measure(count: int, repeat: int) -> dict:
    best: dict = {}
    particles = 0
    for _ in range(repeat):
        with pots_scene(count) as sim:
            particles = int(sim.world.particles.alive.sum())
            record = strike_first_pot(sim)
        for key in COLUMNS:
            best[key] = min(best.get(key, float("inf")), float(record.get(key, float("nan"))))
    return dict(count=count, particles=particles, **best)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--counts", default="1,4,13", help="pots per scene, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="fresh scenes per size (the best is reported)")
    args = ap.parse_args(argv)
    counts = [int(c) for c in args.counts.split(",")]
    if not counts or min(counts) < 1 or args.repeat < 1:
        ap.error("--counts takes integers >= 1 and --repeat an integer >= 1")
    import anisofrac

    info = anisofrac.init()
    with pots_scene(1) as sim:  # warm-up: imports, kernels, caches
        strike_first_pot(sim)
    rows = [measure(c, args.repeat) for c in counts]
    print(f"One fracture event against scene size ({info.device}, {info.arch}, {info.precision}, 1 thread; "
          f"best of {args.repeat})\n")
    print("| pots | particles | whole event ms | stress analysis ms | subdivision ms | crack generation ms |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['count']} | {r['particles']:,} | {r['whole_event_ms']:.1f} | {r['stress_analysis_ms']:.1f} | "
              f"{r['particle_subdivision_ms']:.1f} | {r['crack_generation_ms']:.1f} |")
    base = rows[0]["whole_event_ms"]
    print(f"\nlargest / smallest scene: {rows[-1]['whole_event_ms'] / base:.2f}x the event time for "
          f"{rows[-1]['particles'] / rows[0]['particles']:.1f}x the particles (1.0x: fracture in place)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
