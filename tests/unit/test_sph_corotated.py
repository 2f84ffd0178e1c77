"""sph.corotated: patch tests, rigid motions, anisotropic energy, momentum and energy consistency."""

import numpy as np
import pytest
import scipy.linalg
from scipy.spatial.transform import Rotation

from sph.corotated import CorotatedSPH
from sph.kernel import kernel_from_axes
from sph.materials import energy_density, rotate_stiffness, stiffness_isotropic, stiffness_orthotropic

D = 0.1  # m: lattice spacing of the test block
HF = 2.5  # support radius / spacing (order 2 on disordered particles needs about 2.5)
E_ISO = stiffness_isotropic(1e8, 0.3)
ORTHO = stiffness_orthotropic(12e9, 0.9e9, 0.5e9, 0.4, 0.45, 0.5, 0.7e9, 0.6e9, 0.1e9)


def _block(n: int = 6, jitter: float = 0.25, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    g = np.arange(n) * D
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    return x + rng.uniform(-jitter, jitter, x.shape) * D


def _surface(x0: np.ndarray) -> np.ndarray:
    lo, hi = x0.min(0), x0.max(0)
    return np.any((x0 - lo < 1.3 * D) | (hi - x0 < 1.3 * D), axis=1)


def _aniso_kernels(n: int, seed: int) -> np.ndarray:
    """Per-particle kernels with random axes, lengths 2.2 D .. 3.5 D (ratio <= 1.6)."""
    rng = np.random.default_rng(seed)
    R = Rotation.random(n, random_state=seed).as_matrix()
    h = D * np.column_stack([np.full(n, 2.2), rng.uniform(2.2, 3.5, n), np.full(n, 3.5)])
    return np.stack([kernel_from_axes(R[k], h[k]) for k in range(n)])


X0 = _block()
N = X0.shape[0]
VOL = np.full(N, D**3)


@pytest.fixture(scope="module")
def models(taichi_runtime):
    """order -> CorotatedSPH on the jittered block (isotropic kernel), plus an anisotropic-kernel one."""
    G_iso = np.eye(3) / (HF * D)
    out = {o: CorotatedSPH(X0, VOL, G_iso, E_ISO, order=o) for o in (0, 1, 2)}
    out["aniso2"] = CorotatedSPH(X0, VOL, _aniso_kernels(N, 1), E_ISO, order=2)
    yield out
    for m in out.values():
        m.release()


@pytest.mark.parametrize("key", [1, 2, "aniso2"])
def test_patch_linear_field_exact_with_correction(models, key):
    m = models[key]
    assert m.order_counts[m.order] == N  # every particle corrected, surface included
    A = np.array([[1.0, -2.0, 0.5], [0.3, 0.7, -1.1], [2.0, 0.1, -0.4]]) * 1e-3
    m.set_positions(X0 + X0 @ A.T)
    grad = m.plain_gradient()
    err = np.abs(grad - A).max() / np.abs(A).max()
    assert err < 1e-11, f"linear patch test error {err:.3e}"


def test_patch_error_without_correction_is_reported(models, capsys):
    """Plain SPH (order 0, Eq. 7 as printed): the error is O(1) at the surface; record it."""
    m = models[0]
    A = np.array([[1.0, -2.0, 0.5], [0.3, 0.7, -1.1], [2.0, 0.1, -0.4]]) * 1e-3
    m.set_positions(X0 + X0 @ A.T)
    grad = m.plain_gradient()
    rel = np.linalg.norm(grad - A, axis=(1, 2)) / np.linalg.norm(A)
    surf = _surface(X0)
    with capsys.disabled():
        print(
            f"\n[patch test, no correction, jitter 0.25 D, h = {HF} D] relative gradient error: "
            f"interior max {rel[~surf].max():.3f} mean {rel[~surf].mean():.3f}; "
            f"surface max {rel[surf].max():.3f} mean {rel[surf].mean():.3f}"
        )
    assert rel[surf].mean() > 0.1  # the correction is needed: plain SPH misses a linear field
    assert rel[~surf].max() < rel[surf].max()


@pytest.mark.parametrize("key", [1, 2, "aniso2"])
def test_corotated_patch_stretch_and_rotation(models, key):
    """x = Q (I + A) x0 + t: M (I + grad u) reproduces Q (I + A); eps is the polar stretch - I."""
    m = models[key]
    A = np.array([[2.0, -1.0, 0.5], [0.3, -1.5, 1.1], [0.2, 0.4, 1.0]]) * 1e-3
    Q = Rotation.from_rotvec([0.4, -1.2, 2.0]).as_matrix()
    F = Q @ (np.eye(3) + A)
    m.set_positions(X0 @ F.T + [3.0, -1.0, 2.0])
    m.compute_stress()
    R = m.particle_R.to_numpy()
    gu = m.particle_gradu.to_numpy()
    J = np.einsum("nij,njk->nik", R, np.eye(3) + gu)
    assert np.abs(J - F).max() < 1e-12
    _, P = scipy.linalg.polar(np.eye(3) + A)
    eps = m.particle_strain.to_numpy()
    assert np.abs(eps - (P - np.eye(3))).max() < 1e-9 * np.abs(A).max()


@pytest.mark.parametrize("key", [0, 1, 2, "aniso2"])
def test_rigid_rotation_has_zero_strain_and_energy(models, key):
    m = models[key]
    Q = Rotation.from_rotvec([2.0, 0.5, -1.0]).as_matrix()  # 129 degrees
    m.set_positions(X0 @ Q.T + [1.0, 0.0, -0.5])
    f = m.compute_forces()
    U, Us = m.strain_energy()
    eps = m.particle_strain.to_numpy()
    assert np.abs(eps).max() < 1e-12
    scale = 1e8 * 1e-3**2 * VOL.sum()  # energy of a 1e-3 strain: the scale of real loads
    assert U < 1e-18 * scale and Us == 0.0
    f_ref = 1e8 * 1e-3 * D**2  # N: force of a 1e-3 strain on one particle face
    assert np.abs(f).max() < 1e-9 * f_ref  # = the strain tolerance above


def test_rotated_orthotropic_material_energy(taichi_runtime):
    """Material axes rotated by Q: SPH energy of a uniform strain = energy of Q^T eps Q unrotated."""
    Q = Rotation.from_euler("zyx", [40, -25, 70], degrees=True).as_matrix()
    Cw = rotate_stiffness(ORTHO, Q)
    m = CorotatedSPH(X0, VOL, np.eye(3) / (HF * D), Cw, order=2)
    try:
        S = np.array([[1.0, 0.4, -0.3], [0.4, -0.6, 0.2], [-0.3, 0.2, 0.8]]) * 1e-3
        m.set_positions(X0 @ (np.eye(3) + S).T)
        U, _ = m.strain_energy()
        eps = m.particle_strain.to_numpy()
        _, P = scipy.linalg.polar(np.eye(3) + S)  # symmetric positive S: eps = S exactly
        expected = energy_density(ORTHO, Q.T @ (P - np.eye(3)) @ Q) * VOL.sum()
        assert np.abs(eps - (P - np.eye(3))).max() < 1e-12
        assert U == pytest.approx(expected, rel=1e-9)
        # the same strained body rotated rigidly by Q2 (material turning with it) stores the same energy
        Q2 = Rotation.from_rotvec([-0.3, 1.7, 0.9]).as_matrix()
        m.set_positions(X0 @ (Q2 @ (np.eye(3) + S)).T)
        U2, _ = m.strain_energy()
        assert U2 == pytest.approx(expected, rel=1e-8)
    finally:
        m.release()


def _deformed(seed: int) -> np.ndarray:
    """A smooth non-affine deformation with a large rotation."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(2, 5, 3)
    u = 2e-3 * np.sin(k * X0[:, [1, 2, 0]]) + 1e-3 * rng.standard_normal(X0.shape) * D
    Q = Rotation.from_rotvec([0.7, -0.2, 1.1]).as_matrix()
    return (X0 + u) @ Q.T


@pytest.mark.parametrize("order", [1, 2])
def test_internal_forces_conserve_momentum(order, taichi_runtime):
    """Anisotropic kernels and material, stabilisation on: sum f = 0 and sum x x f = 0 to round-off."""
    C = rotate_stiffness(ORTHO, Rotation.from_euler("x", 30, degrees=True).as_matrix())
    m = CorotatedSPH(X0, VOL, _aniso_kernels(N, 2), C, order=order, stabilisation=0.1)
    try:
        x = _deformed(3)
        m.set_positions(x)
        f = m.compute_forces()
        scale = np.abs(f).sum()
        assert scale > 0
        assert np.abs(f.sum(0)).max() < 1e-13 * scale
        torque = np.cross(x - x.mean(0), f).sum(0)
        assert np.abs(torque).max() < 1e-12 * scale * np.ptp(x)
    finally:
        m.release()


@pytest.mark.parametrize("order,stab", [(1, 0.0), (2, 0.0), (2, 0.1), (1, 0.1)])
def test_forces_are_minus_energy_gradient(order, stab, taichi_runtime):
    """Isotropic material, green_factor off: f = -dE/dx (central differences), stabilisation included."""
    m = CorotatedSPH(X0, VOL, _aniso_kernels(N, 4), E_ISO, order=order, stabilisation=stab, green_factor=False)
    try:
        x = _deformed(5)
        m.set_positions(x)
        f = m.compute_forces()
        rng = np.random.default_rng(6)
        h = 1e-6 * D
        for i in rng.choice(N, 6, replace=False):
            for a in range(3):
                xp = x.copy()
                xp[i, a] += h
                m.set_positions(xp)
                Ep = sum(m.strain_energy())
                xp[i, a] -= 2 * h
                m.set_positions(xp)
                Em = sum(m.strain_energy())
                fd = -(Ep - Em) / (2 * h)
                assert fd == pytest.approx(f[i, a], rel=1e-5, abs=1e-6 * np.abs(f).max())
    finally:
        m.release()


def test_order2_exact_for_quadratic_fields(models):
    """Order 2 gives the exact gradient of a quadratic field at every particle (bending accuracy)."""
    m = models[2]
    c = np.array([0.3, 0.2, 0.1])

    def u(x: np.ndarray) -> np.ndarray:
        y = x - c
        return 1e-3 * np.stack([y[:, 0] * y[:, 1], y[:, 2] ** 2 - y[:, 0] ** 2, y[:, 1] * y[:, 2] + y[:, 0]], 1)

    def grad(x: np.ndarray) -> np.ndarray:
        y = x - c
        z = np.zeros(len(x))
        return 1e-3 * np.stack(
            [
                np.stack([y[:, 1], y[:, 0], z], 1),
                np.stack([-2 * y[:, 0], z, 2 * y[:, 2]], 1),
                np.stack([np.ones(len(x)), y[:, 2], y[:, 1]], 1),
            ],
            1,
        )

    m.set_positions(X0 + u(X0))
    err = np.abs(m.plain_gradient() - grad(X0)).max()
    assert err < 1e-12
    models[1].set_positions(X0 + u(X0))
    assert np.abs(models[1].plain_gradient() - grad(X0)).max() > 1e-5  # order 1 is not
