"""sph.contact fields: Boussinesq (closed form, gradient, equilibrium, free surface, force balance),
the Kirchhoff plate field (gradient, Timoshenko's moments, shear-force balance), effective moduli."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sph.contact import (
    boussinesq_displacement,
    boussinesq_gradient,
    boussinesq_stress,
    effective_isotropic,
    isotropic_stress,
    plate_displacement,
    plate_gradient,
)
from sph.materials import rotate_stiffness, stiffness_isotropic, stiffness_orthotropic

F, E, NU = 1.0e3, 7.0e10, 0.22
G_SHEAR = E / (2 * (1 + NU))


def _points(n: int = 200, seed: int = 0, zmin: float = 0.05) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 3))
    x[:, 2] = np.abs(x[:, 2]) + zmin
    return x


def _fd_gradient(fun, x: np.ndarray, h: float) -> np.ndarray:
    g = np.zeros((x.shape[0], 3, 3))
    for l in range(3):
        d = np.zeros(3)
        d[l] = h
        g[:, :, l] = (fun(x + d) - fun(x - d)) / (2 * h)
    return g


def test_boussinesq_matches_johnsons_polar_form():
    """u_r = F/(4 pi G) [r z/R^3 - (1 - 2 nu)(R - z)/(r R)], u_z = F/(4 pi G) [z^2/R^3 + 2(1 - nu)/R]
    (Johnson eq. 3.19, written independently here in polar form)."""
    x = _points()
    u = boussinesq_displacement(x, F, E, NU)
    r = np.hypot(x[:, 0], x[:, 1])
    z = x[:, 2]
    R = np.linalg.norm(x, axis=1)
    K = F / (4 * math.pi * G_SHEAR)
    ur = K * (r * z / R**3 - (1 - 2 * NU) * (R - z) / (r * R))
    uz = K * (z * z / R**3 + 2 * (1 - NU) / R)
    assert np.allclose(np.hypot(u[:, 0], u[:, 1]), np.abs(ur), rtol=1e-12, atol=0)
    assert np.allclose(u[:, 0] * x[:, 0] + u[:, 1] * x[:, 1], ur * r, rtol=1e-11, atol=1e-25)
    assert np.allclose(u[:, 2], uz, rtol=1e-12, atol=0)
    # on the surface: pushed in (u_z > 0) and drawn towards the load (u_r < 0)
    s = boussinesq_displacement(np.array([[0.3, 0.0, 0.0]]), F, E, NU)[0]
    assert s[2] == pytest.approx(F * (1 - NU) / (2 * math.pi * G_SHEAR * 0.3), rel=1e-12)
    assert s[0] == pytest.approx(-(1 - 2 * NU) * F / (4 * math.pi * G_SHEAR * 0.3), rel=1e-12)


@pytest.mark.parametrize("a", [0.0, 0.2])
def test_boussinesq_gradient_matches_finite_differences(a):
    x = _points(seed=1)
    g = boussinesq_gradient(x, F, E, NU, a)
    fd = _fd_gradient(lambda p: boussinesq_displacement(p, F, E, NU, a), x, 1e-6)
    assert np.abs(fd - g).max() <= 1e-7 * np.abs(g).max()


def test_boussinesq_stresses_are_johnsons():
    """sigma_z = -3F z^3/(2 pi R^5), tau_rz = -3F r z^2/(2 pi R^5),
    sigma_r = F/(2 pi) [(1 - 2nu)/(R (R + z)) - 3 z r^2 / R^5],
    sigma_theta = -(1 - 2 nu) F/(2 pi) [1/(R (R + z)) - z / R^3] (Johnson eq. 3.20)."""
    x = _points(seed=2)
    s = boussinesq_stress(x, F, E, NU)
    r = np.hypot(x[:, 0], x[:, 1])
    z = x[:, 2]
    R = np.linalg.norm(x, axis=1)
    er = np.stack([x[:, 0] / r, x[:, 1] / r, np.zeros_like(r)], axis=1)
    et = np.stack([-x[:, 1] / r, x[:, 0] / r, np.zeros_like(r)], axis=1)
    ez = np.tile([0.0, 0.0, 1.0], (len(x), 1))

    def comp(a, b):
        return np.einsum("ni,nij,nj->n", a, s, b)

    scale = np.abs(s).max(axis=(1, 2))
    ref = {
        "zz": (comp(ez, ez), -3 * F * z**3 / (2 * math.pi * R**5)),
        "rz": (comp(er, ez), -3 * F * r * z**2 / (2 * math.pi * R**5)),
        "rr": (comp(er, er), F / (2 * math.pi) * ((1 - 2 * NU) / (R * (R + z)) - 3 * z * r**2 / R**5)),
        "tt": (comp(et, et), -(1 - 2 * NU) * F / (2 * math.pi) * (1 / (R * (R + z)) - z / R**3)),
        "rt": (comp(er, et), np.zeros_like(r)),
    }
    for name, (got, want) in ref.items():
        assert np.all(np.abs(got - want) <= 1e-11 * scale), name


@pytest.mark.parametrize("a", [0.0, 0.1])
def test_boussinesq_field_is_in_equilibrium(a):
    """div sigma = 0 (Navier) inside the half-space, by central differences of the stress."""
    x = _points(100, seed=3, zmin=0.2)
    h = 1e-4
    div = np.zeros((len(x), 3))
    for l in range(3):
        d = np.zeros(3)
        d[l] = h
        plus = boussinesq_stress(x + d, F, E, NU, a)[:, :, l]
        minus = boussinesq_stress(x - d, F, E, NU, a)[:, :, l]
        div += (plus - minus) / (2 * h)
    scale = np.abs(boussinesq_stress(x, F, E, NU, a)).max(axis=(1, 2)) / np.linalg.norm(x, axis=1)
    assert np.all(np.linalg.norm(div, axis=1) <= 1e-5 * scale)


def test_free_surface_traction():
    """a = 0: sigma_iz = 0 on z = 0 away from the load. a > 0: the surface carries exactly the pressure
    p = 3 F a^3 / (2 pi (r^2 + a^2)^(5/2)) (peak = the Hertz p0 = 3F / (2 pi a^2)) and a shear
    3 F r a^2 / (2 pi (r^2 + a^2)^(5/2)), both negligible against the field (~F / r^2) far away."""
    r = np.linspace(0.05, 2.0, 40)
    pts = np.stack([r * math.cos(0.7), r * math.sin(0.7), np.zeros_like(r)], axis=1)
    s0 = boussinesq_stress(pts, F, E, NU)
    scale = F / (2 * math.pi * r**2)
    assert np.all(np.abs(s0[:, :, 2]).max(axis=1) <= 1e-10 * scale)
    a = 0.01
    s = boussinesq_stress(pts, F, E, NU, a)
    er = np.array([math.cos(0.7), math.sin(0.7), 0.0])
    s_rr = np.einsum("i,nij,j->n", er, s, er)
    p = 3 * F * a**3 / (2 * math.pi * (r**2 + a**2) ** 2.5)
    assert np.allclose(-s[:, 2, 2], p, rtol=1e-9, atol=1e-12 * scale.max())
    tau = np.hypot(s[:, 0, 2], s[:, 1, 2])
    assert np.allclose(tau, 3 * F * r * a**2 / (2 * math.pi * (r**2 + a**2) ** 2.5), rtol=1e-9)
    far = r > 20 * a
    assert np.all(np.abs(s[far, :, 2]).max(axis=1) <= 0.02 * np.abs(s_rr[far]))
    centre = boussinesq_stress(np.zeros((1, 3)), F, E, NU, a)[0]
    assert -centre[2, 2] == pytest.approx(3 * F / (2 * math.pi * a * a), rel=1e-12)


@pytest.mark.parametrize("a", [0.0, 0.05])
def test_vertical_force_on_a_hemisphere_balances_the_load(a):
    """The tractions on a hemisphere |x| = rho (z > 0) carry the load applied inside it:
    int sigma_zj n_j dA = -F (a = 0), -F (1 - a^3 / (rho^2 + a^2)^(3/2)) (a > 0)."""
    rho = 0.3
    mu, wmu = np.polynomial.legendre.leggauss(64)  # cos(theta) in (0, 1)
    c = 0.5 * (mu + 1.0)
    wc = 0.5 * wmu
    phi = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    C, P = np.meshgrid(c, phi, indexing="ij")
    S = np.sqrt(1 - C**2)
    nrm = np.stack([S * np.cos(P), S * np.sin(P), C], axis=-1).reshape(-1, 3)
    sig = boussinesq_stress(rho * nrm, F, E, NU, a)
    tz = np.einsum("nj,nj->n", sig[:, 2, :], nrm).reshape(C.shape)
    total = float((tz * wc[:, None]).sum() * (2 * math.pi / len(phi)) * rho**2)
    expect = -F * (1 - a**3 / (rho**2 + a**2) ** 1.5) if a > 0 else -F
    assert total == pytest.approx(expect, rel=1e-6)


# ----------------------------------------------------------------------------- plate


B, L = 0.01, 0.3


@pytest.mark.parametrize("a", [0.0, 0.004])
def test_plate_gradient_matches_finite_differences(a):
    rng = np.random.default_rng(4)
    x = rng.uniform(-0.1, 0.1, (100, 3))
    x[:, 2] = rng.uniform(0.0, B, 100)
    g = plate_gradient(x, F, E, NU, B, L, a)
    fd = _fd_gradient(lambda p: plate_displacement(p, F, E, NU, B, L, a), x, 1e-7)
    assert np.abs(fd - g).max() <= 1e-6 * np.abs(g).max()


def _moments(r: float, a: float = 0.0) -> tuple[float, float, np.ndarray]:
    z, wz = np.polynomial.legendre.leggauss(8)
    depth = 0.5 * (z + 1.0) * B
    pts = np.stack([np.full(8, r), np.zeros(8), depth], axis=1)
    s = isotropic_stress(plate_gradient(pts, F, E, NU, B, L, a), E, NU)
    zeta = depth - 0.5 * B
    Mr = float((s[:, 0, 0] * zeta * wz).sum() * 0.5 * B)
    Mt = float((s[:, 1, 1] * zeta * wz).sum() * 0.5 * B)
    return Mr, Mt, s


def test_plate_moments_are_timoshenkos():
    """Simply supported circular plate, central load: M_r = F/(4 pi)(1 + nu) ln(L/r),
    M_t = F/(4 pi)[(1 + nu) ln(L/r) + 1 - nu] (Timoshenko & Woinowsky-Krieger eq. 90); plane stress,
    far face in tension with hoop > radial."""
    for r in (0.01, 0.05, 0.2):
        Mr, Mt, s = _moments(r)
        assert Mr == pytest.approx(F / (4 * math.pi) * (1 + NU) * math.log(L / r), rel=1e-10)
        assert Mt == pytest.approx(F / (4 * math.pi) * ((1 + NU) * math.log(L / r) + 1 - NU), rel=1e-10)
        assert np.abs(s[:, 2, 2]).max() <= 1e-10 * np.abs(s).max()
        assert s[-1, 1, 1] > s[-1, 0, 0] > 0.0  # far face (largest depth): hoop > radial > 0


@pytest.mark.parametrize("a", [0.0, 0.01])
def test_plate_shear_force_carries_the_load(a):
    """Plate equilibrium: 2 pi r Q_r = 2 pi r (dM_r/dr + (M_r - M_t)/r) = -(load within r)
    = -F (a = 0), -F (1 - a^4 / (r^2 + a^2)^2) for the regularised load."""
    for r in (0.005, 0.02, 0.08):
        h = 1e-6
        Mr_p, _, _ = _moments(r + h, a)
        Mr_m, _, _ = _moments(r - h, a)
        Mr, Mt, _ = _moments(r, a)
        Q = (Mr_p - Mr_m) / (2 * h) + (Mr - Mt) / r
        expect = -F * (1 - a**4 / (r * r + a * a) ** 2)
        assert 2 * math.pi * r * Q == pytest.approx(expect, rel=1e-5)


# ----------------------------------------------------------------------------- effective moduli


def test_effective_isotropic_is_exact_for_isotropic_and_rotation_invariant():
    E1, nu1 = effective_isotropic(stiffness_isotropic(7e10, 0.22))
    assert E1 == pytest.approx(7e10, rel=1e-12) and nu1 == pytest.approx(0.22, rel=1e-12)
    C = stiffness_orthotropic(12e9, 0.9e9, 0.5e9, 0.4, 0.45, 0.5, 0.7e9, 0.6e9, 0.1e9)
    Q = Rotation.from_euler("zyx", [0.4, -0.9, 1.3]).as_matrix()
    Ea, na = effective_isotropic(C)
    Eb, nb = effective_isotropic(rotate_stiffness(C, Q))
    assert Eb == pytest.approx(Ea, rel=1e-10) and nb == pytest.approx(na, rel=1e-10)
    assert 0.5e9 < Ea < 12e9 and -1.0 < na < 0.5
