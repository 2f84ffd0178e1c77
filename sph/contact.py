"""Classical contact mechanics at an impact (Johnson 1985/1987, ch. 3 and 11): Hertz impact and the
Boussinesq field, the "contact mechanics" of the paper's Sect. 3-4.2 (Fig. 2, Algorithm 1 line 7).

The paper only says that the neighbours' displacements are "evaluated by contact mechanics"; we use
the time-step-free quasi-static solutions below (DESIGN.md, "Contact mechanics at impact").

Hertz impact of two elastic bodies (Johnson, Sect. 11.4, eqs. 11.21-11.24)
------------------------------------------------------------------------
  effective mass     m* = m1 m2 / (m1 + m2)            (m2 = inf: a static collider, m* = m1)
  effective radius   1/R* = 1/R1 + 1/R2               (R2 = inf: a plane; at least one is finite)
  effective modulus  1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2   (E2 = inf: a rigid collider)
  Hertz law          F(d) = 4/3 E* sqrt(R*) d^(3/2)    (d: mutual approach)
  energy balance     1/2 m* v^2 = 8/15 E* sqrt(R*) d_max^(5/2)
  max approach       d_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)
  peak force         F = 4/3 E* sqrt(R*) d_max^(3/2)
  contact radius     a = sqrt(R* d_max),   area S = pi a^2
  peak pressure      p0 = 3 F / (2 pi a^2) = (2/pi) E* sqrt(d_max / R*)    (mean pressure 2/3 p0)
  largest tension    sigma_t,max = (1 - 2 nu1) / 3 p0: the radial stress at the edge of the contact
                     circle on body 1's surface (Johnson eq. 3.63), the Hertzian cone-crack stress.
  duration           t = 2 (d_max/v) int_0^1 dx / sqrt(1 - x^(5/2)) = c_t d_max / v with
                     c_t = (4/5) Gamma(2/5) Gamma(1/2) / Gamma(9/10) = 2.94325... (Johnson: 2.94)
Validity: linear elastic, frictionless, small strains (a << R*), contact radius much smaller than
both bodies, quasi-static: the impact lasts much longer than the time an elastic wave needs to
cross the bodies (Johnson's criterion: v << wave speed; t >> 2 R / c). No plasticity, no
damping: the impact is perfectly elastic (the rigid solver applies its own restitution).

Boussinesq point load on a half-space (Johnson eqs. 3.19-3.20)
-------------------------------------------------------------
Frame: origin at the contact point, +z the INWARD normal (into the body), r the distance from the
z axis, R = |x|, G = E / (2 (1 + nu)), a normal force F > 0 pushing the surface inwards:
  u_r = F/(4 pi G) [ r z / R^3 - (1 - 2 nu) r / (R (R + z)) ]
  u_z = F/(4 pi G) [ z^2 / R^3 + 2 (1 - nu) / R ]
  (Johnson writes the second term of u_r as (1 - 2 nu)(R - z)/(r R); the two are equal because
  (R - z)(R + z) = r^2.) Signs checked here: on the surface u_z = F (1 - nu)/(2 pi G r) > 0 (the
  surface is pushed in), u_r = -(1 - 2 nu) F/(4 pi G r) (it is drawn towards the load), and the
  stresses derived from the gradient by Hooke's law are Johnson's eq. 3.20:
  sigma_z = -3 F z^3/(2 pi R^5), tau_rz = -3 F r z^2/(2 pi R^5), sigma_r on the surface
  = +(1 - 2 nu) F/(2 pi r^2) (tension), sigma_theta on the surface = -(1 - 2 nu) F/(2 pi r^2);
  tests/unit/test_crack_contact.py checks them, the free surface and the force balance.
In Cartesian form (x, y in the surface plane): u_x = x A, u_y = y A, u_z = B with
  A = F/(4 pi G) [ z / R^3 - (1 - 2 nu) / (R (R + z)) ],  B = F/(4 pi G) [ z^2 / R^3 + 2 (1 - nu) / R ].

Regularisation inside the contact patch (a > 0; sph/cracks.py passes l = max(contact radius,
particle radius)): the same field evaluated at z' = z + a, i.e. the Boussinesq solution of a point
load applied a distance a OUTSIDE the surface. It satisfies the
Navier equations exactly in the body (it is a rigid translation of an exact solution), it is smooth
at the contact point, and the pressure it applies on the plane z = 0 is
  p(r) = 3 F a^3 / (2 pi (r^2 + a^2)^(5/2)),   total F,   peak 3 F/(2 pi a^2) = the Hertz p0,
plus a shear traction tau = 3 F r a^2/(2 pi (r^2 + a^2)^(5/2)) (relative size (a/r)^2 far from the
load, where both vanish); the interior field converges to Boussinesq's as R/a grows (relative
difference O(a/R)). Points of the body on the outer side of the tangent plane (z < 0, a concave
surface) are evaluated at z = 0 (their projection on the plane).

Thin bodies: Kirchhoff plate under a central load (Timoshenko & Woinowsky-Krieger 1959, Sect. 19)
----------------------------------------------------------------------------------------------
Where the struck body is thinner than the analysed neighbourhood (a pane, a pot wall), a half-space
is the wrong model: the load is carried by bending, whose tension (on the far face, hoop > radial)
is what makes radial cracks (see docs/notes_cracks.md for the numbers). Simply supported circular
plate of radius L and thickness B, flexural rigidity D = E B^3 / (12 (1 - nu^2)), load F at the
centre, frame as above (z inward from the struck face, zeta = z - B/2 from the mid-surface):
  w(r) = F/(16 pi D) [ (3 + nu)/(1 + nu) (L^2 - r^2) + 2 r^2 ln(r / L) ]
  M_r = F/(4 pi) (1 + nu) ln(L / r),   M_theta = F/(4 pi) [ (1 + nu) ln(L / r) + 1 - nu ]
  (sigma = 12 M zeta / B^3: the far face zeta = +B/2 is in tension, hoop > radial everywhere.)
Regularised by writing the field in s = r^2 + l^2 instead of r^2:
  w(s) = F/(16 pi D) [ (3 + nu)/(1 + nu) (L^2 - s) + s ln(s / L^2) ],
which is the exact Kirchhoff solution (D lap^2 w = q) for the load q(r) = 2 F l^4 / (pi (r^2 + l^2)^3),
total F (simply supported at L up to O(l^2/L^2)). 3D displacement (Kirchhoff kinematics completed
so that sigma_zz = 0 for an isotropic solid):
  u_alpha = -zeta dw/dx_alpha,   u_z = w + nu / (2 (1 - nu)) zeta^2 lap w.
Validity: B << L, |w| << B (small deflection), r >> B (thin-plate theory ignores the local Hertz
field, which the half-space model describes), quasi-static.

Threshold speeds (inverse of the Hertz law): the speed whose peak force is F is
  v(F) = sqrt(16 E* sqrt(R*) d^(5/2) / (15 m*)),  d = (3 F / (4 E* sqrt(R*)))^(2/3);
the speed at which the Hertz tension (1 - 2 nu1)/3 p0 reaches sigma_t (`hertz_threshold_speed`):
  p0 = 3 sigma_t / (1 - 2 nu1),  d = R* (pi p0 / (2 E*))^2,  v = sqrt(16 E* sqrt(R*) d^(5/2) / (15 m*)),
so v_th ~ sigma_t^(5/2) E*^-2 (m* / R*^3)^(-1/2).

Anisotropic materials: the field is that of an effective isotropic solid (E, nu) given by the
Voigt-Reuss-Hill average of the stiffness (`effective_isotropic`); strains from this field are then
turned into stresses with the full anisotropic C (sph/cracks.py), which is where the anisotropy acts.

Gradient convention: grad[k, l] = d u_k / d x_l (as sph/corotated.py).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from core.arrays import cross3
from core.errors import ConfigError

HERTZ_DURATION_CONST = 0.8 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)  # 2.94325: t = c d_max / v


def _positive(key: str, value: float, allow_inf: bool = False) -> float:
    v = float(value)
    ok = v > 0.0 and (math.isfinite(v) or (allow_inf and v == math.inf))
    if not ok:
        raise ConfigError(key, value, "> 0" + (" (inf allowed)" if allow_inf else " and finite"))
    return v


def _poisson(key: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and -1.0 < v < 0.5):
        raise ConfigError(key, value, "-1 < nu < 0.5")
    return v


@dataclass(frozen=True)
class HertzImpact:
    """Result of `hertz_impact` (SI units)."""

    force: float  # N: peak contact force F
    radius_a: float  # m: contact radius a at peak
    area: float  # m^2: contact area S = pi a^2
    duration: float  # s: contact duration
    delta: float  # m: maximum mutual approach d_max
    m_eff: float  # kg: effective mass m*
    R_eff: float  # m: effective radius R*
    E_eff: float  # Pa: effective modulus E*
    speed: float  # m/s: relative normal speed
    p0: float  # Pa: peak contact pressure 3F / (2 pi a^2)

    def to_dict(self) -> dict:
        return {k: float(v) for k, v in asdict(self).items()}


def effective_mass(m1: float, m2: float) -> float:
    """m* = m1 m2 / (m1 + m2); m2 = inf gives m1 (kg)."""
    return m1 if math.isinf(m2) else m1 * m2 / (m1 + m2)


def effective_radius(R1: float, R2: float) -> float:
    """1/R* = 1/R1 + 1/R2 (m); one of them may be inf (a plane)."""
    inv = (0.0 if math.isinf(R1) else 1.0 / R1) + (0.0 if math.isinf(R2) else 1.0 / R2)
    if inv <= 0.0:
        raise ConfigError("impact.(R1, R2)", (R1, R2), "at least one finite radius (two planes have no Hertz contact)")
    return 1.0 / inv


def effective_modulus(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (Pa); E2 = inf is a rigid collider."""
    inv = (1.0 - nu1 * nu1) / E1 + (0.0 if math.isinf(E2) else (1.0 - nu2 * nu2) / E2)
    return 1.0 / inv


def hertz_impact(
    m1: float, m2: float, R1: float, R2: float, E1: float, nu1: float, E2: float, nu2: float, speed: float
) -> HertzImpact:
    """Peak force, contact radius, area, duration of the elastic Hertz impact (module doc formulas).

    m1, m2 (kg; m2 may be inf), R1, R2 (m; either may be inf), E1, E2 (Pa; E2 may be inf),
    nu1, nu2 (-1 < nu < 0.5), speed: relative normal approach speed (m/s, >= 0).
    """
    m1 = _positive("impact.m1", m1)
    m2 = _positive("impact.m2", m2, allow_inf=True)
    R1 = _positive("impact.R1", R1, allow_inf=True)
    R2 = _positive("impact.R2", R2, allow_inf=True)
    E1 = _positive("impact.E1", E1)
    E2 = _positive("impact.E2", E2, allow_inf=True)
    nu1 = _poisson("impact.nu1", nu1)
    nu2 = _poisson("impact.nu2", nu2)
    v = float(speed)
    if not (math.isfinite(v) and v >= 0.0):
        raise ConfigError("impact.speed", speed, ">= 0 m/s and finite")
    ms = effective_mass(m1, m2)
    Rs = effective_radius(R1, R2)
    Es = effective_modulus(E1, nu1, E2, nu2)
    delta = (15.0 * ms * v * v / (16.0 * Es * math.sqrt(Rs))) ** 0.4
    force = 4.0 / 3.0 * Es * math.sqrt(Rs) * delta**1.5
    a = math.sqrt(Rs * delta)
    area = math.pi * a * a
    duration = HERTZ_DURATION_CONST * delta / v if v > 0.0 else 0.0
    p0 = 2.0 / math.pi * Es * math.sqrt(delta / Rs)
    return HertzImpact(force, a, area, duration, delta, ms, Rs, Es, v, p0)


def hertz_max_tension(impact: HertzImpact, nu1: float) -> float:
    """(1 - 2 nu1)/3 p0 (Pa): the largest tensile stress of the Hertz contact (edge of the circle)."""
    return (1.0 - 2.0 * nu1) / 3.0 * impact.p0


def effective_isotropic(C: np.ndarray) -> tuple[float, float]:
    """(E, nu) of the Voigt-Reuss-Hill average of a 6x6 Voigt stiffness (engineering shear).

    Voigt: 9 K_V = (C11 + C22 + C33) + 2 (C12 + C13 + C23),
           15 G_V = (C11 + C22 + C33) - (C12 + C13 + C23) + 3 (C44 + C55 + C66);
    Reuss (S = C^-1): 1/K_R = (S11 + S22 + S33) + 2 (S12 + S13 + S23),
           15/G_R = 4 (S11 + S22 + S33) - 4 (S12 + S13 + S23) + 3 (S44 + S55 + S66);
    Hill: K = (K_V + K_R)/2, G = (G_V + G_R)/2; E = 9 K G / (3 K + G), nu = (3 K - 2 G) / (2 (3 K + G)).
    Exact (E, nu) for an isotropic C.
    """
    C = np.asarray(C, dtype=np.float64)
    S = np.linalg.inv(C)
    d = C[0, 0] + C[1, 1] + C[2, 2]
    o = C[0, 1] + C[0, 2] + C[1, 2]
    s = C[3, 3] + C[4, 4] + C[5, 5]
    KV = (d + 2.0 * o) / 9.0
    GV = (d - o + 3.0 * s) / 15.0
    dS = S[0, 0] + S[1, 1] + S[2, 2]
    oS = S[0, 1] + S[0, 2] + S[1, 2]
    sS = S[3, 3] + S[4, 4] + S[5, 5]
    KR = 1.0 / (dS + 2.0 * oS)
    GR = 15.0 / (4.0 * dS - 4.0 * oS + 3.0 * sS)
    K = 0.5 * (KV + KR)
    G = 0.5 * (GV + GR)
    E = 9.0 * K * G / (3.0 * K + G)
    nu = (3.0 * K - 2.0 * G) / (2.0 * (3.0 * K + G))
    return float(E), float(nu)


def _shifted(r_vec: np.ndarray, a: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points with z' = max(z, 0) + a; returns (x', R', a flag of clamped points)."""
    x = np.array(r_vec, dtype=np.float64, copy=True).reshape(-1, 3)
    clamped = x[:, 2] < 0.0
    x[:, 2] = np.maximum(x[:, 2], 0.0) + a
    R = np.sqrt((x * x).sum(axis=1))
    return x, R, clamped


def _check_field_args(F: float, E: float, nu: float, a: float) -> None:
    _positive("boussinesq.E", E)
    _poisson("boussinesq.nu", nu)
    if not (math.isfinite(float(F)) and math.isfinite(float(a)) and a >= 0.0):
        raise ConfigError("boussinesq.(F, a)", (F, a), "finite force and contact radius a >= 0")


def boussinesq_displacement(r_vec: np.ndarray, F: float, E: float, nu: float, a: float = 0.0) -> np.ndarray:
    """(N,3) displacement (m) at offsets r_vec (N,3) (m) from the contact point, +z inward; normal
    load F (N) on an elastic half-space (E Pa, nu), regularised by the contact radius a (m; module doc).
    a = 0 is the exact Boussinesq field (singular at the origin)."""
    _check_field_args(F, E, nu, a)
    x, R, _ = _shifted(r_vec, a)
    z = x[:, 2]
    K = F * (1.0 + nu) / (2.0 * math.pi * E)  # F / (4 pi G)
    A = K * (z / R**3 - (1.0 - 2.0 * nu) / (R * (R + z)))
    B = K * (z * z / R**3 + 2.0 * (1.0 - nu) / R)
    return np.stack([x[:, 0] * A, x[:, 1] * A, B], axis=1)


def boussinesq_gradient(r_vec: np.ndarray, F: float, E: float, nu: float, a: float = 0.0) -> np.ndarray:
    """(N,3,3) analytic gradient d u_k / d x_l of `boussinesq_displacement` (clamped points: the
    gradient of the field on the plane, with d/dz taken as for z = 0)."""
    _check_field_args(F, E, nu, a)
    x, R, _ = _shifted(r_vec, a)
    n = x.shape[0]
    z = x[:, 2]
    K = F * (1.0 + nu) / (2.0 * math.pi * E)
    c = 1.0 - 2.0 * nu
    R3 = R**3
    R5 = R**5
    Rz = R + z
    A = z / R3 - c / (R * Rz)
    ez = np.zeros((n, 3))
    ez[:, 2] = 1.0
    # dA/dx_l = d_lz / R^3 - 3 z x_l / R^5 + c [x_l (2R + z)/R + R d_lz] / (R^2 (R + z)^2)
    dA = (
        ez / R3[:, None]
        - 3.0 * (z / R5)[:, None] * x
        + (c / (R * R * Rz * Rz))[:, None] * (x * ((2.0 * R + z) / R)[:, None] + R[:, None] * ez)
    )
    # dB/dx_l = 2 z d_lz / R^3 - 3 z^2 x_l / R^5 - 2 (1 - nu) x_l / R^3
    dB = (2.0 * z / R3)[:, None] * ez - (3.0 * z * z / R5)[:, None] * x - (2.0 * (1.0 - nu) / R3)[:, None] * x
    g = np.empty((n, 3, 3))
    g[:, 0, :] = x[:, 0:1] * dA
    g[:, 0, 0] += A
    g[:, 1, :] = x[:, 1:2] * dA
    g[:, 1, 1] += A
    g[:, 2, :] = dB
    return K * g


def speed_for_force(force: float, m_eff: float, R_eff: float, E_eff: float) -> float:
    """Impact speed (m/s) whose Hertz peak force is `force` (N), for effective m*, R*, E* (module doc)."""
    if force <= 0.0:
        return 0.0
    if math.isinf(force):
        return math.inf
    d = (3.0 * force / (4.0 * E_eff * math.sqrt(R_eff))) ** (2.0 / 3.0)
    return math.sqrt(16.0 * E_eff * math.sqrt(R_eff) * d**2.5 / (15.0 * m_eff))


def hertz_threshold_speed(
    m1: float, m2: float, R1: float, R2: float, E1: float, nu1: float, E2: float, nu2: float, sigma_t: float
) -> float:
    """Speed (m/s) at which the Hertz tension (1 - 2 nu1)/3 p0 of body 1 reaches sigma_t (Pa); inf if
    nu1 = 0.5 (no tension). The cone-crack criterion of classical contact mechanics (module doc)."""
    probe = hertz_impact(m1, m2, R1, R2, E1, nu1, E2, nu2, 0.0)
    sigma_t = _positive("sigma_t", sigma_t)
    if 1.0 - 2.0 * nu1 <= 0.0:
        return math.inf
    p0 = 3.0 * sigma_t / (1.0 - 2.0 * nu1)
    d = probe.R_eff * (math.pi * p0 / (2.0 * probe.E_eff)) ** 2
    return math.sqrt(16.0 * probe.E_eff * math.sqrt(probe.R_eff) * d**2.5 / (15.0 * probe.m_eff))


def plate_displacement(
    r_vec: np.ndarray, F: float, E: float, nu: float, thickness: float, outer_radius: float, a: float = 0.0
) -> np.ndarray:
    """(N,3) Kirchhoff-plate displacement (m) at offsets r_vec (N,3) from the load point on the struck
    face (+z inward), plate thickness B (m), support radius L (m), regularisation length a (m)."""
    return _plate(r_vec, F, E, nu, thickness, outer_radius, a, gradient=False)


def plate_gradient(
    r_vec: np.ndarray, F: float, E: float, nu: float, thickness: float, outer_radius: float, a: float = 0.0
) -> np.ndarray:
    """(N,3,3) analytic gradient d u_k / d x_l of `plate_displacement`."""
    return _plate(r_vec, F, E, nu, thickness, outer_radius, a, gradient=True)


def _plate(r_vec, F, E, nu, B, L, a, gradient: bool) -> np.ndarray:
    _check_field_args(F, E, nu, a)
    B = _positive("plate.thickness", B)
    L = _positive("plate.outer_radius", L)
    x = np.asarray(r_vec, dtype=np.float64).reshape(-1, 3)
    D = E * B**3 / (12.0 * (1.0 - nu * nu))
    A = F / (16.0 * math.pi * D)
    kap = nu / (2.0 * (1.0 - nu))
    r2 = x[:, 0] ** 2 + x[:, 1] ** 2
    s = r2 + a * a
    s = np.where(s > 0.0, s, np.finfo(np.float64).tiny)
    zeta = x[:, 2] - 0.5 * B
    ln = np.log(s / (L * L))
    w_s = A * (ln - 2.0 / (1.0 + nu))  # dw/ds
    w_ss = A / s
    w_sss = -A / (s * s)
    lap = 4.0 * w_s + 4.0 * w_ss * r2  # lap w = 4 w_s + 4 w_ss r^2
    if not gradient:
        w = A * ((3.0 + nu) / (1.0 + nu) * (L * L - s) + s * ln)
        return np.stack([-2.0 * zeta * w_s * x[:, 0], -2.0 * zeta * w_s * x[:, 1], w + kap * zeta**2 * lap], axis=1)
    n = x.shape[0]
    g = np.zeros((n, 3, 3))
    xy = x[:, :2]
    # d u_alpha / d x_beta = -zeta (2 w_s d_ab + 4 w_ss x_a x_b);  d u_alpha / dz = -2 w_s x_alpha
    g[:, :2, :2] = -zeta[:, None, None] * (
        2.0 * w_s[:, None, None] * np.eye(2) + 4.0 * w_ss[:, None, None] * xy[:, :, None] * xy[:, None, :]
    )
    g[:, :2, 2] = -2.0 * w_s[:, None] * xy
    # d u_z / d x_beta = 2 w_s x_beta + kap zeta^2 x_beta (16 w_ss + 8 w_sss r^2);  d u_z / dz = 2 kap zeta lap
    g[:, 2, :2] = (2.0 * w_s + kap * zeta**2 * (16.0 * w_ss + 8.0 * w_sss * r2))[:, None] * xy
    g[:, 2, 2] = 2.0 * kap * zeta * lap
    return g


def isotropic_stress(grad: np.ndarray, E: float, nu: float) -> np.ndarray:
    """(N,3,3) Hooke stress (Pa) of displacement gradients (N,3,3) for an isotropic (E, nu)."""
    eps = 0.5 * (grad + np.swapaxes(grad, -1, -2))
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    tr = np.trace(eps, axis1=-2, axis2=-1)
    return 2.0 * mu * eps + lam * tr[..., None, None] * np.eye(3)


def boussinesq_stress(r_vec: np.ndarray, F: float, E: float, nu: float, a: float = 0.0) -> np.ndarray:
    """(N,3,3) stress (Pa) of the (regularised) Boussinesq field, Hooke's law on its gradient."""
    return isotropic_stress(boussinesq_gradient(r_vec, F, E, nu, a), E, nu)


def frame_from_normal(n: np.ndarray, e1: np.ndarray) -> np.ndarray:
    """(3,3) rows (e1, e2, n): a right-handed frame with +z = n and e1 the in-plane part of `e1`."""
    n = np.asarray(n, dtype=np.float64)
    n = n / np.linalg.norm(n)
    t = np.asarray(e1, dtype=np.float64) - np.dot(e1, n) * n
    t = t / np.linalg.norm(t)
    return np.stack([t, cross3(n, t), n])


__all__ = [
    "HERTZ_DURATION_CONST",
    "hertz_threshold_speed",
    "plate_displacement",
    "plate_gradient",
    "speed_for_force",
    "HertzImpact",
    "boussinesq_displacement",
    "boussinesq_gradient",
    "boussinesq_stress",
    "effective_isotropic",
    "effective_mass",
    "effective_modulus",
    "effective_radius",
    "frame_from_normal",
    "hertz_impact",
    "hertz_max_tension",
    "isotropic_stress",
]


def surface_radius(points: np.ndarray, point: np.ndarray, inward: np.ndarray, offset: float = 0.0,
                   flat_ratio: float = 20.0) -> float:
    """Radius of curvature (m) of a body's surface at a contact, for Hertz's R (Johnson Sect. 4.2).

    `points` (K,3) m sample a surface near `point` (the contact), `inward` is the unit normal into
    the body there. The fit z = kappa/2 |p|^2 + b x + c y + d (p relative to the point, z along
    `inward`) is exact for a sphere through the point whose centre lies on the normal (kappa = 1/R)
    and gives kappa = 0 for a plane; for a doubly curved surface kappa is the mean curvature, the
    radius Johnson's equivalent sphere uses. `offset` is added to the fitted radius (centres of
    spheres of radius `offset` lie on a surface `offset` inside the body's). Returns inf for a flat,
    concave or too sparsely sampled patch (fewer than 4 points, or a radius above `flat_ratio` times
    the patch size: a plane for Hertz)."""
    p = np.asarray(points, dtype=np.float64) - np.asarray(point, dtype=np.float64)
    if len(p) < 4:
        return math.inf
    n = np.asarray(inward, dtype=np.float64) / float(np.linalg.norm(inward))
    t1 = cross3(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = cross3(n, t1)
    x, y, z = p @ t1, p @ t2, p @ n
    A = np.stack([0.5 * np.einsum("ij,ij->i", p, p), x, y, np.ones_like(x)], axis=1)
    if np.linalg.matrix_rank(A[:, 1:]) < 3:
        return math.inf  # points on one line: no patch
    kappa = float(np.linalg.lstsq(A, z, rcond=None)[0][0])
    size = float(np.sqrt(x * x + y * y).max())
    if kappa <= 0.0 or 1.0 / kappa > flat_ratio * size:
        return math.inf
    return 1.0 / kappa + offset


def push_profile(kind: str, r_vec: np.ndarray, E: float, nu: float, a: float, thickness: float = 0.0,
                 outer_radius: float = 0.0) -> np.ndarray:
    """(N,) -: the contact's normal displacement at offsets r_vec (N,3) from the contact point (+z
    inward) relative to its value at the point, in [0, 1]: how much of the striker's push the
    material there follows (the shape of the field Algorithm 1 analysed: 'plate' (Kirchhoff, with
    `thickness` and `outer_radius`) or 'halfspace' (Boussinesq), regularised by `a`). Linear in F,
    so F = 1 N; the ratio does not depend on it."""
    r = np.asarray(r_vec, dtype=np.float64).reshape(-1, 3)
    if kind == "plate":
        def u(p):
            return plate_displacement(p, 1.0, E, nu, thickness, outer_radius, a)[:, 2]
    elif kind == "halfspace":
        def u(p):
            return boussinesq_displacement(p, 1.0, E, nu, a)[:, 2]
    else:
        raise ConfigError("push_profile.kind", kind, "'plate' or 'halfspace'")
    at_point = u(np.zeros((1, 3)))[0]
    return np.clip(u(r) / at_point, 0.0, 1.0)
