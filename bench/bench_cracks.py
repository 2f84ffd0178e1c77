"""Benchmark of the crack analysis (Algorithm 1, sph/cracks.py) against the paper's Table 2.

Usage: .venv/bin/python bench/bench_cracks.py [--quick] [--repeat N] [--h-factor F]

For objects of about the paper's particle counts (Glass pane 1.7k, Pot 6k, Tai Chi ~4k, Pet 24k,
Pots 13 x 6.4k = 83k) one impact is analysed (crack count 3, WPCA kernels with h = F x the tet
size, F = 1.2 by default: about 100-200 neighbours in a solid, the cost grows with h^6 there; for
the thin-walled pane and pot h is at least 2.5 x the wall thickness, so that the flattened WPCA
kernel reaches across the wall to its tension face, see docs/notes_cracks.md)
and the wall time per event is printed beside Table 2's "stress analysis" column (Xeon W3530 +
GTX 760), with the ratio paper / ours. Columns: the default analysis (Eq. 7 with the quadratic
correction), Bonet-Lok (correction=1) and the analytic gradient (no SPH; the reference the others
approximate). Times are the median of --repeat runs; building the object and its kernels is not
timed (the paper's column is the analysis at a collision). Host-side numpy: no Taichi is used.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from geometry.build import build_object  # noqa: E402
from sph.cracks import ImpactSpec, analyse_impact  # noqa: E402
from sph.kernel import kernel_wpca  # noqa: E402
from sph.materials import Material, stiffness_isotropic  # noqa: E402

STEEL_BALL = dict(m2=7850.0 * 4.0 / 3.0 * math.pi * 0.03**3, R2=0.03, E2=2.1e11, nu2=0.3)  # Fig. 9: radius 3
GLASS = Material("glass", 2500.0, stiffness_isotropic(7e10, 0.22), tensile_strength=5e7, toughness=10.0)
PORCELAIN = Material("porcelain", 2400.0, stiffness_isotropic(5e10, 0.2), tensile_strength=4e7, toughness=10.0)
PAPER_MS = {"Glass": 91.0, "Pot": 86.0, "Pet": 341.0, "Pots": 588.0, "Tai Chi": 649.0}
PAPER_N = {"Glass": 1743, "Pot": 6163, "Pet": 23664, "Pots": 80119, "Tai Chi": 3880}


def _pot_side(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ring = np.flatnonzero(np.abs(c[:, 1] - 0.08) < 0.01)
    i = ring[np.argmax(np.hypot(c[ring, 0], c[ring, 2]))]
    radial = np.array([c[i, 0], 0.0, c[i, 2]])
    radial /= np.linalg.norm(radial)
    return np.array([0.09 * radial[0], c[i, 1], 0.09 * radial[2]]), -radial


def _top(c: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    i = int(np.argmax(c[:, 1]))
    return c[i] + np.array([0.0, radius[i], 0.0]), np.array([0.0, -1.0, 0.0])


def scenes(quick: bool, hf: float):
    """(name, x, volume, G, material, impact, thickness) per scene; built once."""
    out = []
    pane = build_object("pane", resolution=0.025)
    ps = pane.particles
    G = kernel_wpca(ps.centroid, max(hf * 0.025, 2.5 * pane.thickness))
    imp = ImpactSpec(point=[0.001, 0.002, 0.004], normal=[0, 0, -1], speed=5.0, m1=float(ps.mass.sum()), R1=math.inf,
                     **STEEL_BALL)
    out.append(("Glass", ps.centroid, ps.volume, G, GLASS, imp, pane.thickness))
    pot = build_object("pot")
    ps = pot.particles
    Gpot = kernel_wpca(ps.centroid, max(hf * 0.01, 2.5 * pot.thickness))
    P, n = _pot_side(ps.centroid)
    imp_pot = ImpactSpec(point=P, normal=n, speed=3.4, m1=float(ps.mass.sum()), R1=0.09)  # dropped from 0.6 m
    out.append(("Pot", ps.centroid, ps.volume, Gpot, PORCELAIN, imp_pot, pot.thickness))
    if not quick:
        tai = build_object("taichi", resolution=0.013)
        ps = tai.particles
        G = kernel_wpca(ps.centroid, hf * 0.013)
        P, n = _top(ps.centroid, ps.radius)
        imp = ImpactSpec(point=P, normal=n, speed=5.0, m1=float(ps.mass.sum()), R1=math.inf, **STEEL_BALL)
        out.append(("Tai Chi", ps.centroid, ps.volume, G, PORCELAIN, imp, tai.thickness))
        pet = build_object("pet")
        ps = pet.particles
        G = kernel_wpca(ps.centroid, hf * 0.01)
        P, n = _top(ps.centroid, ps.radius)
        imp = ImpactSpec(point=P, normal=n, speed=5.0, m1=float(ps.mass.sum()), R1=0.05, **STEEL_BALL)
        out.append(("Pet", ps.centroid, ps.volume, G, PORCELAIN, imp, pet.thickness))
    # Pots: 13 copies of the pot 0.3 m apart; the analysed one is the first
    ps = pot.particles
    shifts = np.array([[0.3 * (k % 5), 0.0, 0.3 * (k // 5)] for k in range(13)])
    x = (ps.centroid[None, :, :] + shifts[:, None, :]).reshape(-1, 3)
    out.append(("Pots", x, np.tile(ps.volume, 13), np.tile(Gpot, (13, 1, 1)), PORCELAIN, imp_pot, pot.thickness))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="Glass, Pot and Pots only, 2 repeats")
    ap.add_argument("--repeat", type=int, default=None, help="runs per configuration (median is printed)")
    ap.add_argument("--h-factor", type=float, default=1.2, help="WPCA kernel radius / tet size (default 1.2)")
    args = ap.parse_args()
    repeat = args.repeat or (2 if args.quick else 7)
    variants = [("Eq.7 quad", dict(correction=2)), ("Bonet-Lok", dict(correction=1)),
                ("analytic", dict(gradient="analytic"))]
    print(f"crack analysis per impact event (median of {repeat}), WPCA h = {args.h_factor} x tet size; "
          "paper: Table 2 'stress analysis' (Xeon W3530 + GTX 760)")
    head = f"{'scene':8s} {'particles':>9s} {'paper n':>8s} {'N_p':>5s} {'pairs':>7s} {'field':>9s} {'cracks':>6s} "
    head += " ".join(f"{name + ' ms':>13s}" for name, _ in variants)
    head += f" {'paper ms':>9s} {'paper/ours':>10s}"
    print(head)
    for name, x, vol, G, mat, imp, thick in scenes(args.quick, args.h_factor):
        times = []
        last = None
        for _, kw in variants:
            ts = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                an = analyse_impact(x, vol, G, mat, imp, 3, thick, **kw)
                ts.append((time.perf_counter() - t0) * 1e3)
                last = an if last is None else last
            times.append(statistics.median(ts))
        pairs = last.pairs
        row = f"{name:8s} {len(x):9d} {PAPER_N[name]:8d} {last.particles.size:5d} {pairs:7d} {last.field:>9s} "
        row += f"{len(last.cracks):6d} " + " ".join(f"{t:13.2f}" for t in times)
        row += f" {PAPER_MS[name]:9.0f} {PAPER_MS[name] / times[0]:10.1f}"
        print(row)
    print("(N_p: analysed particles; the analysis is local, so its cost follows N_p and the kernels' neighbour "
          "counts, plus O(n) numpy passes over the body for the nearest particle and the depth column)")


if __name__ == "__main__":
    main()
