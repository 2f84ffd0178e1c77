"""Benchmark: time to build the paper's particle counts (Sect. 5.1 and 5.3).

    .venv/bin/python bench/bench_geometry.py [--quick]

Builds objects whose tet counts match the paper's Table 1 scenarios (about 1.7k, 6k, 24k and 80k
physical particles) and prints the time of each stage: surface sampling + Delaunay + cleaning
(tetrahedralize), particles and links, boundary particles. The paper does not report build times
(it used NETGEN offline); these figures tell a user how long scene start-up takes.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from geometry.boundary import build_boundary_particles  # noqa: E402
from geometry.build import NAMED_SHAPES, make_shape  # noqa: E402
from geometry.particles import build_particles  # noqa: E402
from geometry.tetrahedralize import tetrahedralize  # noqa: E402

# (label, paper's particle count, shape name, resolution giving about that many tets)
CASES = [
    ("Glass (pane)", 1_743, "pane", 0.025),
    ("Pot", 6_163, "pot", 0.01),
    ("Pet", 23_664, "pet", 0.0105),
    ("Pots (one 80k body)", 80_119, "sphere", 0.0085),
]


def run(quick: bool) -> list[dict]:
    rows = []
    for label, paper, name, res in CASES[:2] if quick else CASES:
        kind, params, _ = NAMED_SHAPES[name]
        shape = make_shape(kind, params)
        t0 = time.perf_counter()
        mesh, report = tetrahedralize(shape, res)
        t1 = time.perf_counter()
        ps = build_particles(mesh, 2400.0)
        t2 = time.perf_counter()
        bp = build_boundary_particles(ps.centroid, ps.radius, ps.mass, ps.body, ps.surface)
        t3 = time.perf_counter()
        rows.append(
            dict(
                case=label, paper=paper, tets=len(ps), boundary=len(bp), tet_ms=1e3 * (t1 - t0),
                particle_ms=1e3 * (t2 - t1), boundary_ms=1e3 * (t3 - t2), total_ms=1e3 * (t3 - t0),
                ratio=report["worst_radius_ratio"],
            )
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="only the two smallest cases")
    args = ap.parse_args()
    rows = run(args.quick)
    print(f"{'case':22s} {'paper N':>8s} {'tets':>8s} {'boundary':>8s} {'tetrahedralize':>15s} "
          f"{'particles':>10s} {'boundary':>9s} {'total':>9s}")
    for r in rows:
        print(f"{r['case']:22s} {r['paper']:8,d} {r['tets']:8,d} {r['boundary']:8,d} {r['tet_ms']:12.0f} ms "
              f"{r['particle_ms']:7.0f} ms {r['boundary_ms']:6.0f} ms {r['total_ms']:6.0f} ms")


if __name__ == "__main__":
    main()
