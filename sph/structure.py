"""How the struck body carries an impact: the structural part of the "contact mechanics" that gives
Algorithm 1's virtual particles their displacement (Sect. 3, 4.2, Fig. 2, line 7).

A Hertz contact on a half-space (sph/contact.py) assumes a rigid backing. A pane, a pot wall or a
rod is not rigid: it bends, takes much of the impact's energy as bending energy, and breaks on the
side opposite the impact, where bending puts it in tension. Two pieces live here:

Impact force with the body's compliance in series (`series_impact`)
--------------------------------------------------------------------
Energy balance of the quasi-static impact with two springs in series, the Hertz contact
(F = k_H d^(3/2), k_H = 4/3 E* sqrt(R*), energy 2/5 F^(5/3) k_H^(-2/3)) and the body (energy
E_1 F^2, E_1 = compliance / 2 in J/N^2):
    1/2 m* v^2 = 2/5 F^(5/3) k_H^(-2/3) + E_1 F^2.
E_1 = 0 gives Hertz's force; a slender body takes a far smaller force. Contact radius, area and
peak pressure follow Hertz at that force. E_1 of the structural fields:
  plate (simply supported circular plate of radius L under a central load, Timoshenko &
  Woinowsky-Krieger Sect. 19): w0 = F L^2 (3 + nu) / (16 pi (1 + nu) D), E_1 = w0 / (2 F);
  beam: E_1 = int M(s)^2 / (2 E I) ds at unit force (`Beam.energy`).

Euler-Bernoulli beam struck sideways (`Beam`)
---------------------------------------------
A slender body (rod, bar, a figurine's limb) of length L = s_L + s_R on either side of the load
point (s = 0), bending stiffness E I, mass m spread evenly (mu = m / L), unit load along +n.
  free body ("inertia relief", d'Alembert): the load is balanced by the body's own inertia,
    q(s) = -mu (a + alpha (s - s_c)), a = F/m, alpha = -s_c F / I_c, s_c = (s_R - s_L)/2,
    I_c = m L^2 / 12; the moment at s comes from the free end on its side:
    s <= 0: M_t(s) = mu [a l^2/2 + alpha ((s - s_c) l^2/2 - l^3/3)],  l = s + s_L
    s >= 0: M_t(s) = mu [a l^2/2 + alpha ((s - s_c) l^2/2 + l^3/3)],  l = s_R - s
    (symmetric case: M_t(0) = F L / 8, the classic free-free beam struck at its middle);
  held body (a static bar, simply supported at its ends): M_t = F s_R (s + s_L)/L (s <= 0),
    F s_L (s_R - s)/L (s >= 0).
M_t > 0 puts the far side (z > 0 along the inward normal, measured from the neutral axis) in
tension: sigma_ss = M_t z / I. Displacement (curvature kappa = M_t/(E I), Theta = int_0^s kappa,
W = -int_0^s Theta, y lateral from the section's centroid), Euler-Bernoulli kinematics with the
Poisson contraction of the section, so that Hooke's law gives the uniaxial bending stress:
    u_s = z Theta(s),  u_y = -nu kappa z y,  u_n = W(s) - nu kappa (z^2 - y^2) / 2.
Validity: slender (section much smaller than L), small deflection, quasi-static (the contact lasts
longer than a flexural wave needs to run along the beam; a short impact on a long rod loads only
the part the wave reaches, and then the free-free moment overestimates the compliance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.errors import ConfigError
from sph.contact import HERTZ_DURATION_CONST, HertzImpact

BEAM_SAMPLES = 2001  # points of the tabulated moment, slope and deflection along the beam
STAR_KAPPA = 0.357  # -: prefactor of the radial-crack law (`star_crack_count`), from the PMMA example


def series_impact(hz: HertzImpact, body_energy: float) -> HertzImpact:
    """The impact `hz` with the struck body's compliance (E_1 = body_energy, J/N^2) in series with
    the Hertz contact (module doc). The duration is Hertz's scaled by F_Hertz / F (same momentum)."""
    e1 = float(body_energy)
    if not (math.isfinite(e1) and e1 >= 0.0):
        raise ConfigError("series_impact.body_energy", body_energy, ">= 0 J/N^2 and finite")
    if e1 == 0.0 or hz.force <= 0.0:
        return hz
    kH = 4.0 / 3.0 * hz.E_eff * math.sqrt(hz.R_eff)
    K = 0.5 * hz.m_eff * hz.speed**2

    def energy(F: float) -> float:
        return 0.4 * F ** (5.0 / 3.0) * kH ** (-2.0 / 3.0) + e1 * F * F

    lo, hi = 0.0, min(hz.force, math.sqrt(K / e1))  # each term alone bounds F from above
    for _ in range(200):  # bisection on an increasing function, to float resolution
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if energy(mid) < K else (lo, mid)
    F = 0.5 * (lo + hi)
    delta = (F / kH) ** (2.0 / 3.0)
    a = math.sqrt(hz.R_eff * delta)
    p0 = 3.0 * F / (2.0 * math.pi * a * a) if a > 0.0 else 0.0
    duration = HERTZ_DURATION_CONST * hz.delta / hz.speed * hz.force / F if F > 0.0 and hz.speed > 0.0 else 0.0
    return HertzImpact(F, a, math.pi * a * a, duration, delta, hz.m_eff, hz.R_eff, hz.E_eff, hz.speed, p0)


def star_crack_count(E: float, thickness: float, toughness: float, density: float, speed: float) -> float:
    """Number of radial cracks of a brittle plate struck transversely (`cracks = "auto"`):
    N = STAR_KAPPA (E h / G_c)^(1/2) (rho V^2 / E)^(1/4), the scaling of Vandenberghe, Vermorel and
    Villermaux (Phys. Rev. Lett. 110, 174302, 2013): a Griffith balance of the plate's bending
    energy against the fracture energy of N radial cracks, N growing as the square root of the
    impact speed V and of the thickness h, and falling as the fracture energy G_c grows. STAR_KAPPA
    is set by their published example (1 mm PMMA, E = 3 GPa, rho = 1180 kg/m^3, G_c = K_Ic^2/E =
    333 J/m^2, struck at 22.2 m/s: 4 cracks; at 56.7 m/s they count 8, the law says 6.4)."""
    for key, v in (("E", E), ("thickness", thickness), ("toughness", toughness), ("density", density)):
        if not (math.isfinite(v) and v > 0.0):
            raise ConfigError(f"star_crack_count.{key}", v, "> 0 and finite")
    if not (math.isfinite(speed) and speed >= 0.0):
        raise ConfigError("star_crack_count.speed", speed, ">= 0 m/s and finite")
    return STAR_KAPPA * math.sqrt(E * thickness / toughness) * (density * speed * speed / E) ** 0.25


def plate_energy(E: float, nu: float, thickness: float, outer_radius: float) -> float:
    """E_1 (J/N^2) of a simply supported circular plate under a central load (module doc)."""
    D = E * thickness**3 / (12.0 * (1.0 - nu * nu))
    return outer_radius**2 * (3.0 + nu) / (32.0 * math.pi * (1.0 + nu) * D)


@dataclass
class Beam:
    """An Euler-Bernoulli beam struck at s = 0 by a unit force (module doc); SI units."""

    E: float  # Pa: Young's modulus along the axis
    nu: float  # -: Poisson ratio
    inertia: float  # m^4: second moment of the section about the bending axis
    s_left: float  # m: length on the negative side of the load point
    s_right: float  # m: length on the positive side
    mass: float  # kg: the body's mass (free body)
    held: bool = False  # simply supported at its ends instead of free
    s: np.ndarray = field(init=False, repr=False)  # (S,) m: samples along the axis
    kappa: np.ndarray = field(init=False, repr=False)  # (S,) 1/(m N): curvature per newton
    theta: np.ndarray = field(init=False, repr=False)  # (S,) 1/N: slope
    w: np.ndarray = field(init=False, repr=False)  # (S,) m/N: deflection

    def __post_init__(self) -> None:
        for key in ("E", "inertia", "s_left", "s_right", "mass"):
            v = float(getattr(self, key))
            if not (math.isfinite(v) and v > 0.0):
                raise ConfigError(f"beam.{key}", getattr(self, key), "> 0 and finite")
        sL, sR = self.s_left, self.s_right
        s = np.linspace(-sL, sR, BEAM_SAMPLES)
        self.s = s
        self.kappa = self.moment(s) / (self.E * self.inertia)
        self.theta = self._integral_from_zero(self.kappa)
        self.w = -self._integral_from_zero(self.theta)

    @property
    def length(self) -> float:
        return self.s_left + self.s_right

    def moment(self, s: np.ndarray) -> np.ndarray:
        """M_t(s) (N m per N of load): positive puts the far side in tension (module doc)."""
        s = np.asarray(s, dtype=np.float64)
        sL, sR, L = self.s_left, self.s_right, self.length
        if self.held:
            return np.where(s <= 0.0, sR * (s + sL), sL * (sR - s)) / L
        mu = self.mass / L
        a = 1.0 / self.mass
        sc = 0.5 * (sR - sL)
        alpha = -sc / (self.mass * L * L / 12.0)
        left = np.clip(s + sL, 0.0, None)
        right = np.clip(sR - s, 0.0, None)
        m_left = mu * (a * left**2 / 2.0 + alpha * ((s - sc) * left**2 / 2.0 - left**3 / 3.0))
        m_right = mu * (a * right**2 / 2.0 + alpha * ((s - sc) * right**2 / 2.0 + right**3 / 3.0))
        return np.where(s <= 0.0, m_left, m_right)

    def _integral_from_zero(self, f: np.ndarray) -> np.ndarray:
        """int_0^s f ds on the samples (trapezoid)."""
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(self.s))])
        return cum - np.interp(0.0, self.s, cum)

    def energy(self) -> float:
        """E_1 = int M_t^2 / (2 E I) ds (J/N^2)."""
        m2 = self.moment(self.s) ** 2
        return float(np.sum(0.5 * (m2[1:] + m2[:-1]) * np.diff(self.s))) / (2.0 * self.E * self.inertia)

    def _at(self, s: np.ndarray) -> tuple[np.ndarray, ...]:
        s = np.clip(s, self.s[0], self.s[-1])
        dk = np.gradient(self.kappa, self.s)
        return tuple(np.interp(s, self.s, f) for f in (self.kappa, self.theta, self.w, dk))

    def displacement(self, local: np.ndarray) -> np.ndarray:
        """(N,3) (u_s, u_y, u_n) at local (s, y, z) (N,3): axis, lateral, depth from the neutral axis."""
        s, y, z = local[:, 0], local[:, 1], local[:, 2]
        k, th, w, _ = self._at(s)
        nu = self.nu
        return np.stack([z * th, -nu * k * z * y, w - 0.5 * nu * k * (z * z - y * y)], axis=1)

    def gradient(self, local: np.ndarray) -> np.ndarray:
        """(N,3,3) d u_a / d x_b of `displacement` in the local (s, y, z) frame."""
        s, y, z = local[:, 0], local[:, 1], local[:, 2]
        k, th, _, dk = self._at(s)
        nu = self.nu
        g = np.zeros((len(s), 3, 3))
        g[:, 0, 0], g[:, 0, 2] = z * k, th
        g[:, 1, 0], g[:, 1, 1], g[:, 1, 2] = -nu * dk * z * y, -nu * k * z, -nu * k * y
        g[:, 2, 0] = -th - 0.5 * nu * dk * (z * z - y * y)
        g[:, 2, 1], g[:, 2, 2] = nu * k * y, -nu * k * z
        return g


__all__ = ["Beam", "plate_energy", "series_impact", "star_crack_count"]
