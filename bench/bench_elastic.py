"""Benchmark of the `elastic` effect on the PEERS.md cantilever (not a test; prints a table).

    .venv/bin/python bench/bench_elastic.py [--quick] [--precision f32|f64] [--arch cpu|cuda|auto]
                                           [--threads N]

Beam: 1 m x 0.1 m x 0.1 m, E = 100 MPa, nu = 0.3, rho = 1000 kg/m^3, gravity 9.81, clamped by 3
layers of fixed particles at x < 0; cubic lattice at cell centres, volume = spacing^3, isotropic
kernel h = 2.2 spacings, order-2 gradients (the effect's defaults). Sizes as in PEERS.md:
5, 10 and 15 particles across (1,325 / 10,300 / 34,425 particles).
Columns: ns per particle-step (mean over 200 steps after warm-up), steps needed to settle, and the
tip error after a damped settle (zeta = 0.7 of mode 1, 0.25 s) against Euler-Bernoulli at the
last layer (x_t = L - d/2) and against 14.71 mm at x = L. Settling needs ~40k steps at 15 across:
minutes on a GPU, much longer on 2 CPU cores; --quick times 5 and 10 across and settles only 5.
If `pysplishsplash` imports, SPlisHSPlasH's Becker 2009 would be run on the same beam; it is not
a project dependency, so normally a note is printed instead.
"""

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from core.runtime import init_taichi  # noqa: E402

L, H, E, NU, RHO, G = 1.0, 0.1, 100e6, 0.3, 1000.0, 9.81
NFIX, HF = 3, 2.2
I_SEC = H**4 / 12.0
Q_LOAD = RHO * H * H * G
OMEGA1 = 1.875**2 * math.sqrt(E * I_SEC / (RHO * H * H * L**4))


def w_eb(x: float) -> float:
    """Euler-Bernoulli deflection (m) of the uniformly loaded cantilever at x."""
    return Q_LOAD * x**2 * (6 * L**2 - 4 * L * x + x**2) / (24 * E * I_SEC)


def beam_particles(nc: int):
    """(x0, d, tip mask, x_t): cell-centred lattice of the beam with NFIX fixed layers at x < 0."""
    d = H / nc
    nx = int(round(L / d))
    xs = (np.arange(-NFIX, nx) + 0.5) * d
    ys = (np.arange(nc) + 0.5) * d - H / 2
    X, Y, Z = np.meshgrid(xs, ys, ys, indexing="ij")
    x0 = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    tip = np.abs(x0[:, 0] - xs[-1]) < 1e-9
    return x0, d, tip, float(xs[-1])


def build_beam(nc: int, damping: float = 0.0, order: int = 2, support: float = HF):
    """(effect, x0, tip mask, x_t): the beam's elastic effect, kernel support = `support` spacings."""
    from sph.elastic import ElasticEffect
    from sph.materials import Material, stiffness_isotropic

    x0, d, tip, xt = beam_particles(nc)
    eff = ElasticEffect(
        x0, np.full(len(x0), d**3), np.eye(3) / (support * d), Material("beam", RHO, stiffness_isotropic(E, NU)),
        fixed=x0[:, 0] < 0.0, gravity=(0.0, 0.0, -G), damping=damping, order=order,
    )
    return eff, x0, tip, xt


def run(nc: int, settle: bool) -> dict:
    import taichi as ti

    from sph.elastic import damping_for_ratio

    eff, x0, tip, xt = build_beam(nc, damping_for_ratio(0.7, OMEGA1))
    n = eff.n
    eff.step(5)  # compile and warm up
    ti.sync()
    t0 = time.perf_counter()
    eff.step(200)
    ti.sync()
    ns = (time.perf_counter() - t0) / 200 / n * 1e9
    out = {"nc": nc, "n": n, "ns": ns, "dt": eff.dt, "steps": int(math.ceil(0.25 / eff.dt))}
    if settle:
        eff.step(out["steps"] - 205)
        wt = -float((eff.positions()[tip, 2] - x0[tip, 2]).mean())
        out["err_xt"] = wt / w_eb(xt) - 1.0
        out["err_L"] = wt / w_eb(L) - 1.0
    eff.release()
    return out


def splishsplash_note() -> str:
    try:
        import pysplishsplash  # noqa: F401
    except ImportError:
        return ("pysplishsplash is not installed: SPlisHSPlasH's Becker 2009 peer not run "
                "(PEERS.md: it blows up within 0.07-0.33 s, about 2,100-2,550 ns per particle-step).")
    return ("pysplishsplash imports, but driving it needs the scene set-up described in PEERS.md "
            "(not automated here); see PEERS.md for its numbers.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="time 5 and 10 across; settle only 5 across")
    ap.add_argument("--precision", default="f32", choices=["f32", "f64"])
    ap.add_argument("--arch", default="auto", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (0 = Taichi's default)")
    args = ap.parse_args()
    info = init_taichi(arch=args.arch, precision=args.precision, threads=args.threads)
    print(f"elastic effect benchmark: arch={info.arch} precision={info.precision} device={info.device}")
    sizes = (5, 10) if args.quick else (5, 10, 15)
    rows = []
    for nc in sizes:
        settle = (nc == 5) or not args.quick
        r = run(nc, settle)
        rows.append(r)
        err = "      -           -"
        if "err_xt" in r:
            err = f"{r['err_xt'] * 100:+7.2f} %   {r['err_L'] * 100:+7.2f} %"
        print(f"{r['nc']:>3} across {r['n']:>7,} particles  {r['ns']:>8.0f} ns/particle-step  "
              f"dt {r['dt']:.2e} s  settle {r['steps']:>6} steps  tip error vs w(x_t), vs 14.71 mm: {err}",
              flush=True)
    print(splishsplash_note())


if __name__ == "__main__":
    main()
