"""Benchmark of the SPH building blocks (not a test; prints a table).

    .venv/bin/python bench/bench_sph.py [--quick] [--precision f32|f64] [--arch cpu|cuda|auto]
                                       [--threads N]

Particles: a jittered cubic lattice (jitter 0.25 spacing) of 12^3, 18^3, 29^3 and 43^3 particles
(1.7k, 6k, 24k, 80k), with anisotropic kernels (random axes, semi-axes 2.2 to 3.5 spacings).
Columns, per particle: neighbour search (hashed grid, count + scan + fill; `NeighbourSearch.build`),
the host-side rest operators (numpy, once per body: order-1 Bonet-Lok and order-2 fits), and one
deformation-gradient + polar decomposition + strain + stress evaluation (`CorotatedSPH.compute_stress`,
order 2) and stress + forces (`compute_forces`). Each timed call is repeated and the median taken.
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from core.runtime import init_taichi  # noqa: E402


def block(k: int, d: float = 0.01, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    from scipy.spatial.transform import Rotation

    g = np.arange(k) * d
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    rng = np.random.default_rng(seed)
    x = x + rng.uniform(-0.25, 0.25, x.shape) * d
    n = len(x)
    R = Rotation.random(n, random_state=seed).as_matrix()
    h = d * np.column_stack([np.full(n, 2.2), rng.uniform(2.2, 3.5, n), np.full(n, 3.5)])
    G = np.einsum("nij,nj,nkj->nik", R, 1.0 / h, R)
    return x, G


def timed(fn, repeat: int) -> float:
    import taichi as ti

    fn()
    ti.sync()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ti.sync()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="only the two smaller sizes")
    ap.add_argument("--precision", default="f32", choices=["f32", "f64"])
    ap.add_argument("--arch", default="auto", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (0 = Taichi's default)")
    args = ap.parse_args()
    info = init_taichi(arch=args.arch, precision=args.precision, threads=args.threads)

    from sph.corotated import CorotatedSPH
    from sph.materials import stiffness_isotropic
    from sph.neighbours import NeighbourSearch

    print(f"SPH benchmark: arch={info.arch} precision={info.precision} device={info.device}")
    print(f"{'particles':>10} {'nbrs/p':>7} {'search ns/p':>12} {'rest-op us/p':>13} "
          f"{'stress ns/p':>12} {'stress+force ns/p':>18}")
    sizes = (12, 18) if args.quick else (12, 18, 29, 43)
    C = stiffness_isotropic(1e8, 0.3)
    for k in sizes:
        x, G = block(k)
        n = len(x)
        ns = NeighbourSearch(n)
        ns.set_points(x, G)
        t_search = timed(ns.build, 5)
        nbrs = ns.total / n
        ns.release()
        t0 = time.perf_counter()
        m = CorotatedSPH(x, np.full(n, 1e-6), G, C, order=2)
        t_setup = time.perf_counter() - t0  # includes its own search and the numpy rest operators
        m.set_positions(x * 1.001)
        t_stress = timed(m.compute_stress, 10)
        t_force = timed(m.compute_forces, 10)
        m.release()
        print(f"{n:>10,} {nbrs:>7.1f} {t_search / n * 1e9:>12.0f} {(t_setup - t_search) / n * 1e6:>13.2f} "
              f"{t_stress / n * 1e9:>12.0f} {t_force / n * 1e9:>18.0f}", flush=True)


if __name__ == "__main__":
    main()
