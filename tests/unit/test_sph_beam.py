"""The `elastic` effect on a cantilever beam under gravity, against Euler-Bernoulli theory.

Beam (PEERS.md): 1 m x 0.1 m x 0.1 m, E = 100 MPa, nu = 0.3, rho = 1000 kg/m^3, g = 9.81 m/s^2,
clamped by 3 layers of fixed particles at x < 0. Particles: a cubic lattice of spacing d = 0.1 / nc
at cell centres (x = (k + 1/2) d), volume d^3. Kernel: isotropic, support h = 2.2 d; quadratic-
consistent gradients (order 2, the elastic effect's default). Euler-Bernoulli:
w(x) = q x^2 (6 L^2 - 4 L x + x^2) / (24 E I), tip q L^4 / (8 E I) = 14.71 mm; the simulated tip is
the mean deflection of the last particle layer (x_t = L - d/2) and is compared with w(x_t) (the
like-for-like value; the error against 14.71 mm is printed too). First period 2 pi / omega_1,
omega_1 = 1.875^2 sqrt(E I / (rho A L^4)) = 32.09 rad/s.
"""

import math

import numpy as np
import pytest

from bench.bench_elastic import OMEGA1, L, build_beam, w_eb
from sph.elastic import damping_for_ratio

T1 = 2.0 * math.pi / OMEGA1


def settle(nc: int, t_end: float = 0.25) -> tuple[float, float, float]:
    """Damped run (zeta = 0.7 of mode 1): (tip deflection m, x_tip m, final KE / max KE)."""
    eff, x0, tip, xt = build_beam(nc, damping=damping_for_ratio(0.7, OMEGA1))
    try:
        nsteps = int(math.ceil(t_end / eff.dt))
        kmax = 0.0
        for _ in range(20):
            eff.step(nsteps // 20)
            kmax = max(kmax, eff.energies()["kinetic"])
        wt = -(eff.positions()[tip, 2] - x0[tip, 2]).mean()
        return wt, xt, eff.energies()["kinetic"] / kmax
    finally:
        eff.release()


@pytest.mark.slow  # about 20-40 s: runs in CI's slow pass (.ci/run)
def test_undamped_energy_and_first_period():
    """Released from rest with gravity on at t = 0, no damping, coarse beam (nc = 4, 688 particles).

    'Start' energy: total (kinetic + strain + gravity potential, datum at the rest positions) at
    t = 0, which is 0. Its rise is measured against the largest kinetic energy of the run (the
    energy being exchanged), the period between the first two downward crossings of the tip's
    mid-level."""
    eff, x0, tip, xt = build_beam(4)
    try:
        t_end = 1.5 * T1
        nsteps = int(math.ceil(t_end / eff.dt))
        every = 4
        e0 = eff.energies()["total"]
        ts, zs, tot, kin = [0.0], [0.0], [e0], [0.0]
        for _ in range(nsteps // every):
            eff.step(every)
            en = eff.energies()
            ts.append(eff.time)
            zs.append((eff.positions()[tip, 2] - x0[tip, 2]).mean())
            tot.append(en["total"])
            kin.append(en["kinetic"])
        ts, zs, tot, kin = map(np.asarray, (ts, zs, tot, kin))
        rise = (tot.max() - e0) / kin.max()
        drop = (e0 - tot.min()) / kin.max()
        mid = 0.5 * (zs.max() + zs.min())
        k = np.nonzero((zs[:-1] > mid) & (zs[1:] <= mid))[0]
        assert len(k) >= 2, "the tip must cross its mid-level downwards twice in 1.5 T1"
        tc = ts[k] + (ts[k + 1] - ts[k]) * (zs[k] - mid) / (zs[k] - zs[k + 1])
        period = tc[1] - tc[0]
        print(
            f"\n[beam nc=4 undamped] dt {eff.dt:.3e} s, {nsteps} steps; energy rise {rise * 100:.4f} % "
            f"drop {drop * 100:.4f} % of max KE {kin.max():.4f} J; period {period:.4f} s vs "
            f"{T1:.4f} s ({(period / T1 - 1) * 100:+.2f} %); mean tip {-mid * 1e3:.2f} mm vs "
            f"w(x_t) {w_eb(xt) * 1e3:.2f} mm"
        )
        assert rise <= 0.01
        assert abs(period / T1 - 1.0) < 0.10
    finally:
        eff.release()


@pytest.mark.slow
def test_damped_tip_deflection_converges():
    """Damped (zeta = 0.7 of mode 1, 0.25 s = 8 time constants): nc = 4 and nc = 8; the finer is
    within 10 % of Euler-Bernoulli and closer than the coarser."""
    res = {}
    for nc in (4, 8):
        wt, xt, kin_ratio = settle(nc)
        err = wt / w_eb(xt) - 1.0
        res[nc] = err
        print(
            f"\n[beam nc={nc} damped] tip {wt * 1e3:.3f} mm vs w(x_t) {w_eb(xt) * 1e3:.3f} mm: "
            f"{err * 100:+.2f} % (vs 14.71 mm at x = L: {(wt / w_eb(L) - 1) * 100:+.2f} %), "
            f"final KE / max KE {kin_ratio:.1e}"
        )
        assert kin_ratio < 1e-3  # settled
    assert abs(res[8]) < 0.10
    assert abs(res[8]) < abs(res[4])
