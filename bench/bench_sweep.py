"""Benchmark: a 4-point sweep on a LocalCluster with 1 worker and with 2 workers, and the speed-up.

    .venv/bin/python bench/bench_sweep.py [--scene glass_r3] [--frames 30] [--grid KEY=V1,V2,V3,V4]

Each configuration starts a fresh cluster (worker processes compile Taichi's kernels on their first
task, as a real sweep does) and writes into its own temporary folder, so nothing is resumed. A
one-frame warm-up run first fills the tet cache (geometry/build_cache.py), as any earlier run of the
scene would have: without the cache, two processes meshing at once on this 2-core machine make
Netgen 5-8x slower, and the speed-up measured 1.46-1.54x. The
table gives wall seconds for the whole sweep (cluster start to last row) and the sum of the runs'
own wall seconds (what the workers computed).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from anisofrac.sweep import SweepSpec, run_sweep, split_values  # noqa: E402
from anisofrac.sweep_results import Rows  # noqa: E402


def time_sweep(scene: str, grid: str, frames: int, workers: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench_sweep_") as tmp:
        out = Path(tmp) / "sweep"
        t0 = time.perf_counter()
        result = run_sweep(SweepSpec(scene=scene, grids=[grid], frames=frames, out=out, workers=workers,
                                     progress=False))
        wall = time.perf_counter() - t0
        rows = Rows(out / "runs.parquet").rows
    return dict(workers=workers, wall_s=wall, runs_s=sum(r["wall_s"] or 0.0 for r in rows), ok=result.ok,
                failed=result.failed, hashes=sorted(r["state_hash"] or "" for r in rows))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="glass_r3")
    p.add_argument("--frames", type=int, default=30)
    p.add_argument("--grid", default="objects.ball.velocity=[0,0,-6],[0,0,-8],[0,0,-10],[0,0,-12]")
    args = p.parse_args(argv)
    time_sweep(args.scene, args.grid.split("=", 1)[0] + "=" + split_values(args.grid.split("=", 1)[1])[0], 1, 1)
    results = [time_sweep(args.scene, args.grid, args.frames, n) for n in (1, 2)]
    base = results[0]["wall_s"]
    print(f"sweep of {args.scene}, {args.frames} frames per run, grid {args.grid}")
    print(f"{'workers':>7} | {'sweep wall s':>12} | {'sum of runs s':>13} | {'ok/failed':>9} | speed-up")
    print("-" * 62)
    for r in results:
        print(f"{r['workers']:>7} | {r['wall_s']:>12.2f} | {r['runs_s']:>13.2f} | "
              f"{r['ok']:>4}/{r['failed']:<4} | {base / r['wall_s']:.2f}x")
    same = results[0]["hashes"] == results[1]["hashes"]
    print(f"state hashes equal across worker counts: {same}")
    return 0 if same and all(r["failed"] == 0 for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
