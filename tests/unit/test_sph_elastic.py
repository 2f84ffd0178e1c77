"""sph.elastic: conservation laws, stability at rest, boundary conditions and the time-step rule."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sph.elastic import CFL_DEFAULT, DT_OPERATOR_SAFETY, ElasticEffect
from sph.kernel import kernel_from_axes
from sph.materials import Material, rotate_stiffness, stiffness_isotropic, stiffness_orthotropic, wave_speed_max

D = 0.05  # m: spacing
RUBBER = Material("rubber", 1100.0, stiffness_isotropic(5e6, 0.4))
WOOD = Material(
    "wood", 600.0,
    rotate_stiffness(stiffness_orthotropic(2e8, 2e7, 1e7, 0.4, 0.45, 0.5, 1.5e7, 1.2e7, 0.4e7),
                     Rotation.from_euler("zx", [30, 50], degrees=True).as_matrix()),
)


def _block(n: int, jitter: float, seed: int = 0) -> np.ndarray:
    g = np.arange(n) * D
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    return x + np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * D


def _aniso(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    R = Rotation.random(n, random_state=seed).as_matrix()
    return np.stack([kernel_from_axes(R[k], D * np.array([2.5, rng.uniform(2.5, 3.5), 3.5])) for k in range(n)])


def _momenta(eff: ElasticEffect) -> tuple[np.ndarray, np.ndarray]:
    x, v = eff.positions(), eff.velocities()
    m = eff.particle_mass.to_numpy()[:, None]
    return (m * v).sum(0), np.cross(x, m * v).sum(0)


def test_free_body_conserves_momentum_anisotropic():
    """Anisotropic material and kernels, no gravity, spinning and deforming: P and L stay constant."""
    x0 = _block(5, 0.2)
    n = len(x0)
    eff = ElasticEffect(x0, np.full(n, D**3), _aniso(n, 1), WOOD, gravity=(0, 0, 0))
    try:
        rng = np.random.default_rng(2)
        c = x0.mean(0)
        v = np.array([0.3, -0.1, 0.2]) + np.cross([2.0, -1.0, 3.0], x0 - c) + 0.05 * rng.standard_normal(x0.shape)
        eff.set_state(x0, v)
        P0, L0 = _momenta(eff)
        e0 = eff.energies()["total"]
        eff.step(400)
        P1, L1 = _momenta(eff)
        scale = eff.particle_mass.to_numpy().sum() * np.abs(v).max()
        assert np.abs(P1 - P0).max() < 1e-12 * scale
        assert np.abs(L1 - L0).max() < 1e-11 * scale * np.ptp(x0)
        assert abs(eff.energies()["total"] - e0) < 0.01 * e0
    finally:
        eff.release()


def test_free_fall_accelerates_at_g():
    x0 = _block(4, 0.0)
    eff = ElasticEffect(x0, np.full(len(x0), D**3), np.eye(3) / (2.2 * D), RUBBER, gravity=(0, 0, -9.81))
    try:
        eff.step(100)
        t = eff.time
        np.testing.assert_allclose(eff.velocities(), np.broadcast_to([0, 0, -9.81 * t], x0.shape), atol=1e-12)
        np.testing.assert_allclose(eff.positions() - x0, np.broadcast_to([0, 0, -4.905 * t * t], x0.shape),
                                   atol=1e-12)
    finally:
        eff.release()


@pytest.mark.parametrize("order", [1, 2])
def test_disordered_block_stable_at_rest_and_perturbed(order):
    """PEERS: Becker 2009 blows up even at rest. Here: at rest nothing moves; kicked with random
    velocities, the energy stays bounded without drift (jittered particles, h = 2.5 spacings, 3000 steps)."""
    x0 = _block(6, 0.25, seed=3)
    n = len(x0)
    eff = ElasticEffect(x0, np.full(n, D**3), np.eye(3) / (2.5 * D), RUBBER, gravity=(0, 0, 0), order=order)
    try:
        eff.step(500)
        assert np.abs(eff.positions() - x0).max() < 1e-12 * D
        v = 1e-2 * np.random.default_rng(4).standard_normal((n, 3))
        v -= v.mean(0)
        eff.set_state(x0, v)
        e0 = eff.energies()["total"]
        es = []
        for _ in range(30):
            eff.step(100)
            es.append(eff.energies()["total"])
        es = np.array(es)
        # A random kick excites every mode, up to omega dt ~ 1, where velocity Verlet's energy
        # measure oscillates by a few % (bounded, no drift); the test is that nothing grows.
        assert np.max(np.abs(es - e0)) < 0.05 * e0
        assert abs(es[-10:].mean() - es[:10].mean()) < 0.002 * e0
        assert np.abs(eff.positions() - x0).max() < 0.2 * D  # small oscillations, no drift or blow-up
    finally:
        eff.release()


def test_fixed_particles_hold():
    x0 = _block(4, 0.0)
    fixed = x0[:, 2] < 0.5 * D
    eff = ElasticEffect(x0, np.full(len(x0), D**3), np.eye(3) / (2.2 * D), RUBBER, fixed=fixed)
    try:
        eff.step(300)
        x = eff.positions()
        assert np.all(x[fixed] == x0[fixed]) and np.all(eff.velocities()[fixed] == 0.0)
        assert np.all(x[~fixed, 2] < x0[~fixed, 2])  # the rest sags under gravity
    finally:
        eff.release()


def test_time_step_rule():
    """dt = cfl h_min / c_max on a lattice; on disordered particles with order 2 at h = 2.2 spacings
    the discrete operator is stiffer and the operator check lowers dt to 0.7 * 2 / omega_max."""
    x0 = _block(5, 0.0)
    n = len(x0)
    eff = ElasticEffect(x0, np.full(n, D**3), np.eye(3) / (2.2 * D), RUBBER, order=1)
    try:
        assert eff.dt == pytest.approx(CFL_DEFAULT[1] * 2.2 * D / wave_speed_max(RUBBER), rel=1e-12)
        assert eff.dt < DT_OPERATOR_SAFETY * 2.0 / eff.omega_max
    finally:
        eff.release()
    xj = _block(5, 0.25, seed=5)
    eff = ElasticEffect(xj, np.full(n, D**3), np.eye(3) / (2.2 * D), RUBBER, order=2)
    try:
        assert eff.dt_rule == pytest.approx(CFL_DEFAULT[2] * 2.2 * D / wave_speed_max(RUBBER), rel=1e-12)
        assert eff.dt == pytest.approx(DT_OPERATOR_SAFETY * 2.0 / eff.omega_max, rel=1e-12)
        assert eff.dt < eff.dt_rule  # the operator check was needed here
    finally:
        eff.release()
