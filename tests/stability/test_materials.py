"""Nearly incompressible and strongly anisotropic materials in the elastic effect: stable at the
time step the effect reports (energy bounded without drift over 3,000 steps after a random kick),
and what the CFL rule `sph.elastic.stable_time_step` alone gives."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sim.guards import TimeStepError, check_time_step
from sph.elastic import CFL_DEFAULT, ElasticEffect, stable_time_step
from sph.kernel import kernel_isotropic
from sph.materials import Material, stiffness_isotropic, stiffness_orthotropic, stiffness_transverse

D = 0.02  # m: particle spacing
AXES = Rotation.from_euler("zx", [30, 50], degrees=True).as_matrix()
MATERIALS = {
    "isotropic nu 0.3": Material("a", 2000.0, stiffness_isotropic(1e9, 0.3)),
    "isotropic nu 0.49": Material("b", 2000.0, stiffness_isotropic(1e9, 0.49)),
    "isotropic nu 0.499": Material("c", 2000.0, stiffness_isotropic(1e9, 0.499)),
    # E1 : E2 : E3 = 100 : 10 : 1, shear 1e9 / 5e8 / 1e8 Pa, axes rotated off the lattice
    "orthotropic 100:1": Material("d", 2000.0, stiffness_orthotropic(2e10, 2e9, 2e8, 0.3, 0.4, 0.45, 1e9, 5e8, 1e8,
                                                                     axes=AXES)),
    # stiff fibres along (1, 1, 0): E_axial / E_transverse = 50, soft axial shear
    "transverse 50:1": Material("e", 2000.0, stiffness_transverse([1.0, 1.0, 0.0], 5e10, 1e9, 0.3, 0.25, 2e8)),
}
RULE_UNSTABLE = ("isotropic nu 0.3", "isotropic nu 0.49", "isotropic nu 0.499", "orthotropic 100:1")


def block(n: int = 6, jitter: float = 0.25, seed: int = 3) -> np.ndarray:
    g = np.arange(n) * D
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    return x + np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * D


def kicked_run(eff: ElasticEffect, blocks: int = 30, steps: int = 100) -> tuple[float, np.ndarray]:
    """Random zero-mean kick (1 cm/s), then blocks x steps; the total energy after each block."""
    x = eff.positions()
    v = 1e-2 * np.random.default_rng(4).standard_normal(x.shape)
    v -= v.mean(0)
    eff.set_state(x, v)
    e0 = eff.energies()["total"]
    es = []
    for _ in range(blocks):
        eff.step(steps)
        e = eff.energies()["total"]
        es.append(e)
        if not (np.isfinite(e) and e < 1e3 * e0):
            break
    return e0, np.array(es)


@pytest.mark.parametrize("name", list(MATERIALS))
def test_stable_at_the_effect_time_step(name):
    """Jittered 6^3 block (jitter 0.25 spacing), isotropic kernel h = 2.5 spacings, order 2, no gravity:
    at the effect's dt (CFL rule, lowered to 0.7 x 2 / omega_max of the measured operator) the energy
    stays within 5% and does not drift (mean of the last 1,000 steps vs the first 1,000: < 0.5%)."""
    x = block()
    mat = MATERIALS[name]
    G = kernel_isotropic(2.5 * D)
    eff = ElasticEffect(x, np.full(len(x), D**3), G, mat, gravity=(0.0, 0.0, 0.0))
    try:
        rule = stable_time_step(np.broadcast_to(G, (len(x), 3, 3)), [mat], CFL_DEFAULT[2])
        assert eff.dt <= rule and check_time_step(eff)["elastic"] == pytest.approx(eff.dt, rel=1e-12)
        e0, es = kicked_run(eff)
        assert len(es) == 30 and np.all(np.isfinite(es))
        assert np.abs(es - e0).max() < 0.05 * e0
        assert abs(es[-10:].mean() - es[:10].mean()) < 0.005 * e0
        assert np.all(np.isfinite(eff.positions())) and np.abs(eff.positions() - x).max() < 0.1 * D
    finally:
        eff.release()


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=(
        "sph/elastic.py stable_time_step: the CFL rule (cfl 0.15 x h_min / c_max for order 2) is above the "
        "stability limit of the order-2 operator on a jittered block (h = 2.5 spacings, jitter 0.25): the "
        "energy grows 1000x; only the operator check (ElasticEffect's default, 0.57-0.74 x the rule) is stable. "
        "The guard sim.guards.check_time_step measures the operator and refuses the rule's step.")))
    if n in RULE_UNSTABLE else n for n in MATERIALS])
def test_stable_at_the_cfl_rule(name):
    x = block()
    eff = ElasticEffect(x, np.full(len(x), D**3), kernel_isotropic(2.5 * D), MATERIALS[name], gravity=(0.0, 0.0, 0.0),
                        check_operator=False)
    try:
        e0, es = kicked_run(eff)
        assert len(es) == 30 and np.abs(es - e0).max() < 0.05 * e0
    finally:
        eff.release()


@pytest.mark.parametrize("name", RULE_UNSTABLE)
def test_guard_refuses_the_unstable_rule_step(name):
    eff = ElasticEffect(block(), np.full(6**3, D**3), kernel_isotropic(2.5 * D), MATERIALS[name],
                        gravity=(0.0, 0.0, 0.0), check_operator=False)
    try:
        with pytest.raises(TimeStepError, match="elastic.dt"):
            check_time_step(eff)
    finally:
        eff.release()
