"""Crack generation at an impact: the paper's Algorithm 1 (Sect. 4.2, Fig. 2, Eq. 1, 7, 8, 11, U_limit).

`analyse_impact` runs one analysis on the host (numpy, float64; the neighbourhood is tens to a few
hundred particles, everything is vectorised, no Python loop per particle):

 1. Contact (sph/contact.py): the Hertz impact of the two bodies gives the peak force F, the contact
    radius a and area S = pi a^2. The struck body's (E1, nu1) is the Hill average of its stiffness.
    Where the struck wall bends (plate, beam; step 3) its compliance E_1 is in series with the Hertz
    contact (sph/structure.py, series_impact): 1/2 m* v^2 = 2/5 F^(5/3) k_H^(-2/3) + E_1 F^2.
 2. Algorithm 1, lines 1-6: the kernel G_P of the particle nearest to P; the analysed set N_p is
    every particle with |G_P (x - P)| < 1; for a wall that bends, G_P's kernel swept along the normal
    from P to the wall's far face (so the far side's bending tension is analysed).
 3. Line 7 ("virtual particles", Fig. 2): every member and every SPH neighbour of a member gets the
    contact displacement, in the frame (e1, e2, n) at P (n = inward normal):
      field 'halfspace': Boussinesq (regularised, sph/contact.py);
      field 'plate':     the Kirchhoff plate under a central load (sph/contact.py);
      field 'beam':      an Euler-Bernoulli beam along the wall's long axis (sph/structure.py);
      field 'auto':      from the struck wall (StruckWall): the particles between the struck face
                         and the wall's far face at depth d_n, with their in-plane spread. d_n: the
                         depths (x - P).n of the particles within one tet edge (of the nearest
                         particle) of the normal line through P, sorted, up to the first gap wider
                         than two tet edges (the far wall of a hollow body is not the struck wall),
                         plus the nearest particle's radius. A wall thinner than 1/4 of its length
                         bends: a 'beam' when it is also narrow (width < 0.35 length, < 3 d_n), else
                         a 'plate'; otherwise a 'halfspace'. The plate thickness is min(thickness,
                         d_n), its mid-surface at the mean of the column's smallest and largest
                         centroid depth, its support radius L that of a disc of the wall's area
                         (at least 2 rho_P).
    Regularisation length l = max(a, r_P) (r_P: radius of the nearest particle): below the particle
    size the field is not resolved by the SPH gradient anyway, and with a <= r_P the analysis is
    exactly linear in F (the threshold speed is then analytic, `threshold_speed`).
 4. Lines 10-11, grouping (a documented departure: the paper sorts by |r| and splits, which makes
    rings, not radial cracks): member i gets the angle theta_i of (x_i - P) about n, measured from
    the reference direction e1, and group k = floor(((theta_i + pi/N) mod 2 pi) / (2 pi/N)): sector
    k is centred on the bisector b_k = cos(2 pi k/N) e1 + sin(2 pi k/N) e2. e1 is, in this order:
    ImpactSpec.reference projected onto the tangent plane; the longest in-plane axis of the kernel
    G_P (the eigenvector of the smallest eigenvalue of the in-plane block of G_P^2, which defines
    the kernel's section |G_P r| < 1 in the plane), when the two in-plane lengths differ by more
    than 1e-6 relative; else the coordinate axis least aligned with n (lowest index on ties). Its
    sign makes its largest component positive. Deterministic.
 5. Lines 13-14, per member (Eq. 7, 1, 8): grad u_i = sum_j (u_j - u_i) (x) d_ij over j with
    |G_i (x_j - x_i)| < 1 (each member's own kernel, gathered as sph/neighbours.py does), with
      correction 0 (False): d_ij = V_j grad W, grad W = k G_i^2 (x_j - x_i) (Eq. 4; Eq. 7 as printed);
      correction 1 (True):  d_ij = V_j L_i grad W, L_i = (sum_j V_j grad W (x) (x_j - x_i))^-1
                            (Bonet-Lok; I when |det| < 1e-6 of its scale) - sph/corotated.py's order 1;
      correction 2 (default): weighted least squares of u_j - u_i by a linear plus quadratic
                            polynomial in x_j - x_i (weights V_j k_ij, the ones Bonet-Lok implies;
                            basis scaled by the support radius; pseudo-inverse with a 1e-6 relative
                            cut, so a thin neighbourhood loses only the directions it cannot see).
    Why 2 by default: in a plate the in-plane curvature of the deflection w(r) leaks into the
    estimated d u_z/dz of a one-sided, thin neighbourhood; with Bonet-Lok the relative gradient error
    is 0.11-0.37 and the crack normals of the pane turn by up to 80 degrees (ring instead of radial
    cracks); with the quadratic fit it is 0.006-0.03 (docs/notes_cracks.md). gradient='analytic'
    uses the field's exact gradient at the members instead (the reference of the accuracy study).
    eps_i = (grad u + grad u^T)/2 (Eq. 1, small strain), sigma_i = C eps_i (Voigt,
    sph/materials.py), U_i = V_i/2 eps_i : sigma_i (Eq. 8).
    Per group, weights w_i = V_i cos^2(theta_i - theta_k): members near the bisector count most.
    (An axisymmetric field averaged with uniform weights over a sector of pi or 2 pi is isotropic in
    the plane - the mean of e_r (x) e_r over a half circle is I/2 - so for N = 1, 2 the crack
    direction would come from discretisation noise.) Group values: the weighted means of grad u,
    eps, sigma; the energy U_g = sum_i U_i over the members; and the TENSILE stress
    T_g = weighted mean of sigma_i^+ (sigma^+ = sum_k max(s_k, 0) v_k v_k^T, the tensile part as in
    O'Brien & Hodgins 1999). Rankine (lines 15-16, with the principal STRESS that the paper's text
    names; line 15 prints lambda_max(eps)) is a point criterion: the group fires when the largest
    tensile principal stress of one of its members exceeds the material's tensile strength (the
    crack starts at the peak); the crack normal is the eigenvector of lambda_max(T_g) (sph.eigen).
    Why T_g and not the mean stress: a plate's bending stress changes sign through the thickness,
    so its mean over members spanning the thickness is ~0; a half-space's mean stress is compressive
    (docs/notes_cracks.md). Plane stress where the wall is thin: for the plate field the stresses
    are projected on the tangent plane, and for a half-space struck on the edge of a thin body (a
    coin on its rim) off the thin in-plane axis.
 6. Crack region: a half-disc through P with that normal, on the side s_g = b_k projected onto the
    crack plane (normalised); if b_k is within ~6 degrees of the normal, the inward normal n
    projected instead; N = 1 gives a full disc (side None).
 7. Eq. 11, r_outer (a dimensionally consistent reading): the energy released by a through-thickness
    crack of length r in a body of thickness B is G_c B r, and the contact area S weights it relative
    to S_ref, the face area of the nearest particle's tet (the paper's Fig. 9 "weight"):
        r_outer,g = (S / S_ref) U'_g / (G_c B),  clamped to [rho_P, L_body],
    rho_P = the analysed kernel's support radius, L_body = the largest distance from P to a particle.
    U'_g = U_g min(1, K / sum_g U_g), K = 1/2 m* v^2: the quasi-static field cannot store more than
    the kinetic energy the impact brings (the Hertz force assumes a rigid backing; a compliant body
    takes less). Particle geometry is that of a regular tet of the particle's volume V:
    edge e = (6 sqrt2 V)^(1/3), face area sqrt3/4 e^2.
 8. U_limit, r_inner (Sect. 4.2, read with the poly6 kernel's cube): the released energy
    U = sum_g U'_g is spread as the energy density u(r) = 315/(64 pi h^9) (h^2 - r^2)^3 U, h = rho_P.
    A particle shatters where u exceeds the energy density needed to free it completely, i.e. to
    create crack area equal to half its surface (each face it frees is one side of a crack it shares
    with a neighbour): u_limit = G_c A_P / (2 V_P) (regular tet: A = sqrt3 e^2).
    r_inner^2 = h^2 - (64 pi h^9 u_limit / (315 U))^(1/3) when positive, else r_inner = 0. Cracks
    carry r_inner only if at least one group fired.

Validity: that of the contact models (sph/contact.py): linear elastic, small strain, quasi-static
impact; a normal impact (friction and the tangential speed are ignored); the contact point P lies
on the struck surface with n its inward normal.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from geometry.cutting import Crack, in_region, signed_distance
from sim.errors import ConfigError
from sph.contact import (
    HertzImpact,
    boussinesq_displacement,
    boussinesq_gradient,
    effective_isotropic,
    hertz_impact,
    hertz_threshold_speed,
    plate_displacement,
    plate_gradient,
    speed_for_force,
)
from sph.eigen import sym_eig3_np
from sph.kernel import GRAD_NORM
from sph.materials import Material, strain_to_voigt, stress_from_voigt
from sph.structure import Beam, plate_energy, series_impact, star_crack_count

FIELDS = ("auto", "halfspace", "plate", "beam")
STRUCTURAL_DEPTH = 0.25  # depth / longest in-plane size of the struck wall below which it bends (plate, beam)
SLENDER_WIDTH = 0.35  # width / length of the struck wall below which it is a beam ...
SLENDER_DEPTH = 3.0  # ... when its width is also under this many depths (a compact section)
GRADIENTS = ("sph", "analytic")  # Eq. 7 on the particles, or the field's exact gradient (reference)
MAX_CRACKS = 64  # crack_count limit (a sector narrower than ~6 degrees holds no particle)
DET_TOL = 1e-6  # relative |det B_i| below which the Bonet-Lok correction falls back to I
SIDE_MIN = 0.1  # |side projection| below which the side falls back (angle to the normal < ~6 deg)
ISO_TOL = 1e-6  # relative difference of in-plane kernel lengths below which G_P has no in-plane axis
CORRECTIONS = (0, 1, 2)  # gradient orders: plain SPH, Bonet-Lok, quadratic WLS
QUAD_RCOND = 1e-6  # relative singular-value cut of the quadratic moment matrix (pseudo-inverse)


@dataclass
class ImpactSpec:
    """One contact event on the struck body (reference frame of that body, SI units)."""

    point: np.ndarray  # (3,) m: contact point P on the struck surface
    normal: np.ndarray  # (3,) -: INWARD unit normal at P (into the struck body)
    speed: float  # m/s: relative normal approach speed (> 0)
    m1: float  # kg: mass of the struck body
    R1: float  # m: local radius of curvature of the struck body at P (inf: flat)
    m2: float = math.inf  # kg: mass of the other body (inf: static collider)
    R2: float = math.inf  # m: radius of the other body (inf: a plane)
    E2: float = math.inf  # Pa: Young's modulus of the other body (inf: rigid)
    nu2: float = 0.25  # -: its Poisson ratio
    reference: np.ndarray | None = None  # (3,) -: in-plane reference direction e1 (None: from the kernel)
    held: bool = False  # the struck body is held by the scene (static): a beam is supported at its ends

    def __post_init__(self) -> None:
        p = np.asarray(self.point, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ConfigError("impact.point", self.point, "three finite coordinates (m)")
        n = np.asarray(self.normal, dtype=np.float64).reshape(-1)
        nn = float(np.linalg.norm(n)) if n.shape == (3,) else 0.0
        if not (math.isfinite(nn) and nn > 0.0):
            raise ConfigError("impact.normal", self.normal, "a finite non-zero 3-vector (inward normal)")
        v = float(self.speed)
        if not (math.isfinite(v) and v > 0.0):
            raise ConfigError("impact.speed", self.speed, "> 0 m/s and finite")
        self.point, self.normal, self.speed = p, n / nn, v
        if self.reference is not None:
            r = np.asarray(self.reference, dtype=np.float64).reshape(-1)
            if r.shape != (3,) or not np.all(np.isfinite(r)):
                raise ConfigError("impact.reference", self.reference, "three finite numbers or None")
            r_in = r - np.dot(r, self.normal) * self.normal
            if np.linalg.norm(r_in) <= 1e-6 * max(np.linalg.norm(r), 1e-300):
                raise ConfigError("impact.reference", self.reference, "a direction not parallel to the normal")
            self.reference = r_in / np.linalg.norm(r_in)


@dataclass
class ImpactAnalysis:
    """Everything one analysis found (unit of each field in its comment). Group arrays have N rows."""

    cracks: list[Crack]  # cracks of the fired groups (Algorithm 1 output)
    hertz: HertzImpact  # the contact (F, a, S, duration, ...)
    field: str  # 'halfspace' or 'plate': the displacement model used
    E1: float  # Pa: effective isotropic Young's modulus of the struck body (Hill)
    nu1: float  # -: its Poisson ratio
    nearest: int  # index of the particle nearest to P (its kernel is G_P)
    kernel: np.ndarray  # (3,3) 1/m: G_P
    support_radius: float  # m: rho_P = 1 / lambda_min(G_P)
    frame: np.ndarray  # (3,3): rows e1, e2, n
    regularisation: float  # m: l = max(a, r_P)
    plate_thickness: float  # m: plate thickness used (0 for 'halfspace')
    plate_radius: float  # m: plate support radius L (0 for 'halfspace')
    body_energy: float  # J/N^2: the struck wall's compliance energy E_1 in series with Hertz (0: rigid backing)
    depth: float  # m: measured depth of the body below P (d_n)
    particles: np.ndarray  # (M,) int: the analysed set N_p (indices into x)
    pairs: int  # member-neighbour pairs of the SPH gradient (0 for the analytic gradient)
    group: np.ndarray  # (M,) int: group of each analysed particle
    theta: np.ndarray  # (M,) rad: angle about n from e1
    bisector: np.ndarray  # (N,3): b_k
    members: np.ndarray  # (N,) int: particles per group
    grad_u: np.ndarray  # (N,3,3) 1: weighted mean displacement gradient (Eq. 7)
    strain: np.ndarray  # (N,3,3) 1: weighted mean strain (Eq. 1)
    stress: np.ndarray  # (N,3,3) Pa: weighted mean stress C eps
    tension: np.ndarray  # (N,3,3) Pa: weighted mean tensile stress T_g (the Rankine stress)
    principal_stress: np.ndarray  # (N,3) Pa: eigenvalues of T_g, descending
    principal_dir: np.ndarray  # (N,3): eigenvector of the largest (the crack normal)
    tension_per_newton: np.ndarray  # (N,) Pa/N: the group's peak member tension / F (the Rankine stress)
    energy: np.ndarray  # (N,) J: U_g (Eq. 8, summed over members)
    energy_available: np.ndarray  # (N,) J: U'_g (capped by the impact's kinetic energy)
    fired: np.ndarray  # (N,) bool: Rankine criterion met
    r_outer: np.ndarray  # (N,) m: crack radius (0 where not fired)
    side: np.ndarray  # (N,3): half-disc side (zeros for a full disc or no crack)
    r_inner: float  # m: shatter radius (U_limit); attached to the cracks only when one fired
    u_limit: float  # J/m^3: shatter threshold energy density
    kinetic_energy: float  # J: 1/2 m* v^2
    tensile_strength: float  # Pa
    elapsed_ms: float  # ms: wall time of the analysis (time.perf_counter)
    timings: dict = field(default_factory=dict)  # ms per stage

    def to_dict(self) -> dict:
        """Plain floats / ints / lists for stats.json."""

        def f(a) -> list | float:
            return np.asarray(a, dtype=np.float64).tolist()

        return {
            "hertz": self.hertz.to_dict(),
            "field": self.field,
            "E1": float(self.E1),
            "nu1": float(self.nu1),
            "nearest": int(self.nearest),
            "support_radius": float(self.support_radius),
            "regularisation": float(self.regularisation),
            "plate_thickness": float(self.plate_thickness),
            "plate_radius": float(self.plate_radius),
            "body_energy": float(self.body_energy),
            "depth": float(self.depth),
            "analysed_particles": int(self.particles.size),
            "pairs": int(self.pairs),
            "groups": [
                {
                    "members": int(self.members[k]),
                    "bisector": f(self.bisector[k]),
                    "principal_stress": f(self.principal_stress[k]),
                    "principal_dir": f(self.principal_dir[k]),
                    "peak_tension": float(self.tension_per_newton[k] * self.hertz.force),
                    "energy": float(self.energy[k]),
                    "energy_available": float(self.energy_available[k]),
                    "fired": bool(self.fired[k]),
                    "r_outer": float(self.r_outer[k]),
                }
                for k in range(len(self.members))
            ],
            "cracks": [
                {
                    "point": f(c.point),
                    "normal": f(c.normal),
                    "r_outer": float(c.r_outer),
                    "side": None if c.side is None else f(c.side),
                    "r_inner": float(c.r_inner),
                }
                for c in self.cracks
            ],
            "r_inner": float(self.r_inner),
            "u_limit": float(self.u_limit),
            "kinetic_energy": float(self.kinetic_energy),
            "tensile_strength": float(self.tensile_strength),
            "elapsed_ms": float(self.elapsed_ms),
            "timings_ms": {k: float(v) for k, v in self.timings.items()},
        }


# ----------------------------------------------------------------------------- helpers


def tet_edge(volume: float) -> float:
    """Edge (m) of the regular tet of this volume (m^3)."""
    return float(np.cbrt(6.0 * math.sqrt(2.0) * volume))


def _reference_direction(GP: np.ndarray, n: np.ndarray, reference: np.ndarray | None) -> np.ndarray:
    if reference is not None:
        e1 = reference - np.dot(reference, n) * n
    else:
        axes = np.eye(3)
        helper = axes[int(np.argmin(np.abs(n)))]  # least aligned with n (argmin: lowest index on ties)
        t1 = helper - np.dot(helper, n) * n
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(n, t1)
        T = np.stack([t1, t2])
        G2 = GP @ GP
        block = T @ G2 @ T.T  # in-plane section of the support: |G r|^2 = r^T G^2 r
        w, v = np.linalg.eigh(block)
        if w[1] - w[0] > ISO_TOL * w[1]:
            e1 = T.T @ v[:, 0]  # smallest eigenvalue: the longest in-plane axis
        else:
            e1 = t1
    e1 = e1 / np.linalg.norm(e1)
    k = int(np.argmax(np.abs(e1) - 1e-12 * np.arange(3)))
    return -e1 if e1[k] < 0.0 else e1


@dataclass
class StruckWall:
    """The part of the struck body that carries the impact: the particles between the struck face
    and the far face of the wall under P (a hollow body's far wall excluded), with the principal
    in-plane axes of their spread (volume-weighted)."""

    x: np.ndarray  # (W,3) m: offsets from P of the wall's particles
    volumes: np.ndarray  # (W,) m^3
    depth_of: np.ndarray  # (W,) m: their depth along n
    edges: np.ndarray  # (W,) m: their tet edges
    frame: np.ndarray  # (3,3) rows: long in-plane axis, short in-plane axis, n
    length: float  # m: extent along the long axis (centroids plus one tet edge)
    width: float  # m: extent along the short axis
    _y_bar: float = 0.0  # m: lateral offset of the section centroid (set by `beam`)
    _z_bar: float = 0.0  # m: depth of the neutral axis (set by `beam`)

    @property
    def axis(self) -> np.ndarray:
        return self.frame[0]

    @property
    def volume(self) -> float:
        return float(self.volumes.sum())

    def kind(self, depth: float) -> str:
        """'auto' field: a wall much thinner than it is long bends: a beam when it is also narrow
        with a compact section, else a plate; a thick body is a half-space."""
        if depth >= STRUCTURAL_DEPTH * self.length:
            return "halfspace"
        if self.width < SLENDER_WIDTH * self.length and self.width < SLENDER_DEPTH * depth:
            return "beam"
        return "plate"

    def local(self, offsets: np.ndarray) -> np.ndarray:
        """(N,3) beam coordinates (s, y, z) of offsets from P: along the axis, lateral from the
        section's centroid, depth from its neutral axis (set by `beam`)."""
        q = offsets @ self.frame.T
        return q - np.array([0.0, self._y_bar, self._z_bar])

    def beam(self, E_axis: float, nu: float, mass: float, held: bool, e_near: float) -> Beam:
        """Euler-Bernoulli beam of this wall (sph/structure.py): ends at its extremes along the
        axis, section from the particles within a slab |s| < 2 tet edges of P: area = wall volume /
        length, second moment = area x (variance of depth, plus e^2/20 per tet: a regular tet's own
        variance along any axis)."""
        q = self.x @ self.frame.T
        s = q[:, 0]
        slab = np.abs(s) < max(2.0 * e_near, 1e-12)
        if slab.sum() < 2:
            slab = np.argsort(np.abs(s))[: min(8, len(s))]
        v = self.volumes[slab]
        self._y_bar = float(np.average(q[slab, 1], weights=v))
        self._z_bar = float(np.average(q[slab, 2], weights=v))
        k2 = float(np.average((q[slab, 2] - self._z_bar) ** 2 + self.edges[slab] ** 2 / 20.0, weights=v))
        pad = 0.5 * float(self.edges.mean())
        s_left, s_right = max(-float(s.min()) + pad, pad), max(float(s.max()) + pad, pad)
        area = self.volume / (s_left + s_right)
        return Beam(E_axis, nu, area * k2, s_left, s_right, mass, held=held)


def _struck_wall(d: np.ndarray, depth: np.ndarray, volume: np.ndarray, n: np.ndarray, z_far: float,
                 e_near: float) -> StruckWall:
    """The struck wall (StruckWall) from offsets d (N,3) from P, depths (N,), volumes (N,)."""
    inw = np.flatnonzero((depth >= -e_near) & (depth <= z_far + e_near))
    if inw.size == 0:
        inw = np.array([int(np.argmin(np.einsum("ij,ij->i", d, d)))])
    x, v = d[inw], volume[inw]
    q = x - np.outer(x @ n, n)
    cov = np.einsum("w,wi,wj->ij", v, q, q) / v.sum()
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    t1 = helper - np.dot(helper, n) * n
    t1 /= np.linalg.norm(t1)
    T = np.stack([t1, np.cross(n, t1)])
    w, vec = np.linalg.eigh(T @ cov @ T.T)
    a = T.T @ vec[:, 1]  # largest spread: the long axis
    k = int(np.argmax(np.abs(a) - 1e-12 * np.arange(3)))
    a = -a if a[k] < 0.0 else a
    frame = np.stack([a, np.cross(n, a), n])
    e = np.cbrt(6.0 * math.sqrt(2.0) * v)
    length = float(np.ptp(q @ a)) + float(e.mean())
    width = float(np.ptp(q @ frame[1])) + float(e.mean())
    return StruckWall(x, v, x @ n, e, frame, length, width)


def E_along(C: np.ndarray, axis: np.ndarray) -> float:
    """Young's modulus (Pa) along a unit axis of the Voigt stiffness C: 1/E = v^T C^-1 v with
    v = (a_x^2, a_y^2, a_z^2, a_y a_z, a_x a_z, a_x a_y) (uniaxial stress along the axis)."""
    a = np.asarray(axis, dtype=np.float64)
    v = np.array([a[0] ** 2, a[1] ** 2, a[2] ** 2, a[1] * a[2], a[0] * a[2], a[0] * a[1]])
    return float(1.0 / (v @ np.linalg.solve(C, v)))


def neighbour_pairs(x: np.ndarray, G: np.ndarray, members: np.ndarray, local: np.ndarray) -> tuple:
    """Pairs (e, j) with member members[e] and local particle j != it, |G_i (x_j - x_i)| < 1
    (gather with the member's own kernel, as sph/neighbours.py). Returns (owner e, index j), sorted."""
    Gm = G[members]
    rho = 1.0 / np.linalg.eigvalsh(Gm)[:, 0]
    tm = cKDTree(x[members])
    tl = cKDTree(x[local])
    sdm = tm.sparse_distance_matrix(tl, float(rho.max()) * (1.0 + 1e-12), output_type="ndarray")
    e = sdm["i"].astype(np.int64)
    j = local[sdm["j"].astype(np.int64)]
    keep = j != members[e]
    e, j = e[keep], j[keep]
    xi = x[j] - x[members[e]]
    q = np.linalg.norm(np.einsum("eab,eb->ea", Gm[e], xi), axis=1)
    keep = q < 1.0
    e, j = e[keep], j[keep]
    order = np.lexsort((j, e))
    return e[order], j[order]


def _quad_basis(X: np.ndarray) -> np.ndarray:
    """(E,9) linear and quadratic monomials of scaled offsets X (E,3)."""
    return np.concatenate([X, X * X, X[:, [0]] * X[:, [1]], X[:, [0]] * X[:, [2]], X[:, [1]] * X[:, [2]]], axis=1)


def sph_gradient(
    x: np.ndarray,
    volume: np.ndarray,
    G: np.ndarray,
    u: np.ndarray,
    members: np.ndarray,
    owner: np.ndarray,
    nbr: np.ndarray,
    correction: bool | int = 2,
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 7 at each member: grad u_i = sum_j (u_j - u_i) (x) d_ij (module doc, step 5).

    x (N,3), volume (N,), G (N,3,3), u (N,3) (rows needed: members and their neighbours), pairs
    (owner, nbr) from `neighbour_pairs`. correction: 0/False plain SPH (Eq. 7 as printed),
    1/True Bonet-Lok, 2 quadratic weighted least squares. Returns (grad (M,3,3), order used (M,))."""
    order = int(correction)
    if order not in CORRECTIONS:
        raise ConfigError("analyse_impact.correction", correction, "0/False (plain), 1/True (Bonet-Lok), 2 (quadratic)")
    m = members.size
    used = np.zeros(m, dtype=np.int64)
    if owner.size == 0:
        return np.zeros((m, 3, 3)), used
    # padded layout (member, slot): every sum over a member's neighbours is a batched matmul
    cnt = np.bincount(owner, minlength=m)
    start = np.concatenate([[0], np.cumsum(cnt)[:-1]])
    slot = np.arange(owner.size) - start[owner]
    K = int(cnt.max())

    def pad(vals: np.ndarray) -> np.ndarray:
        out = np.zeros((m, K) + vals.shape[1:])
        out[owner, slot] = vals
        return out

    i = members[owner]
    xi = x[nbr] - x[i]
    Gm = G[members]
    Gi = Gm[owner]
    Gx = np.einsum("eab,eb->ea", Gi, xi)
    q = np.linalg.norm(Gx, axis=1)
    inside = (q > 0.0) & (q < 1.0)
    qs = np.where(inside, q, 1.0)
    k = np.where(inside, GRAD_NORM * np.linalg.det(Gm)[owner] * (1.0 - qs) ** 2 / qs, 0.0)
    g = k[:, None] * np.einsum("eab,eb->ea", Gi, Gx)  # grad W(x_i - x_j, G_i) = k G^2 (x_j - x_i)
    Vg = pad(volume[nbr][:, None] * g)  # (m, K, 3) plain SPH weights V_j grad W (Eq. 7, 10)
    d = Vg
    if order >= 1:
        Bm = np.matmul(Vg.transpose(0, 2, 1), pad(xi))  # sum_j V_j grad W (x) xi
        scale = np.sqrt((Bm * Bm).sum(axis=(1, 2)) / 3.0)
        det = np.linalg.det(Bm)
        ok = (scale > 0.0) & (np.abs(det) > DET_TOL * scale**3)
        L = np.tile(np.eye(3), (m, 1, 1))
        if ok.any():
            L[ok] = np.linalg.inv(Bm[ok])
        used[ok] = 1
        d = np.matmul(Vg, L.transpose(0, 2, 1))  # d_ij = L_i V_j grad W
    if order == 2:
        srad = 1.0 / np.linalg.eigvalsh(Gm)[:, 0]  # support radius: scales the basis
        w = pad(volume[nbr] * k)  # WLS weights V_j k_ij (the weights Bonet-Lok implies)
        pb = pad(_quad_basis(xi / srad[owner, None]))  # (m, K, 9)
        ok2 = cnt >= 9
        if ok2.any():
            Mq = np.matmul(pb[ok2].transpose(0, 2, 1), w[ok2][:, :, None] * pb[ok2])
            Mi = np.linalg.pinv(Mq, rcond=QUAD_RCOND, hermitian=True)
            c = np.matmul(pb[ok2], Mi)[:, :, :3] * (w[ok2] / srad[ok2, None])[:, :, None]
            d = d.copy()
            d[ok2] = c
            used[ok2] = 2
    du = pad(u[nbr] - u[i])
    grad = np.matmul(du.transpose(0, 2, 1), d)  # sum_j (u_j - u_i) (x) d_ij
    return grad, used


def _tensile_part(sig: np.ndarray) -> np.ndarray:
    """(M,3,3) sigma^+ = sum_k max(s_k, 0) v_k v_k^T (LAPACK eigh, vectorised; exact for symmetric input)."""
    if sig.shape[0] == 0:
        return sig.copy()
    w, v = np.linalg.eigh(sig)
    return np.einsum("mik,mk,mjk->mij", v, np.maximum(w, 0.0), v)


# ----------------------------------------------------------------------------- Algorithm 1


def analyse_impact(
    x: np.ndarray,
    volume: np.ndarray,
    G: np.ndarray,
    material: Material,
    impact: ImpactSpec,
    crack_count: int,
    thickness: float,
    correction: bool | int = 2,
    field: str = "auto",
    gradient: str = "sph",
) -> ImpactAnalysis:
    """Algorithm 1 at the contact point (module doc). x (N,3) m reference-frame rest centroids of the
    struck body's alive particles, volume (N,) m^3, G (N,3,3) or (3,3) 1/m kernel tensors, material
    (stiffness, tensile_strength, toughness G_c), impact: ImpactSpec, crack_count N >= 1, thickness
    B (m, Eq. 11), correction: Bonet-Lok kernel correction of Eq. 7, field: 'auto', 'halfspace' or
    'plate' or 'beam'. Raises ConfigError on bad input."""
    clock = time.perf_counter
    t0 = clock()
    tim: dict = {}
    x = np.asarray(x, dtype=np.float64)
    volume = np.asarray(volume, dtype=np.float64).reshape(-1)
    n_all = x.shape[0] if x.ndim == 2 else 0
    if x.ndim != 2 or x.shape[1] != 3 or n_all == 0 or not np.all(np.isfinite(x)):
        raise ConfigError("analyse_impact.x", getattr(x, "shape", x), "(N,3) finite positions, N >= 1")
    if volume.shape != (n_all,) or not np.all(volume > 0.0) or not np.all(np.isfinite(volume)):
        raise ConfigError("analyse_impact.volume", volume.shape, f"({n_all},) finite volumes > 0")
    G = np.asarray(G, dtype=np.float64)
    if G.shape == (3, 3):
        G = np.broadcast_to(G, (n_all, 3, 3))
    if G.shape != (n_all, 3, 3) or not np.all(np.isfinite(G)):
        raise ConfigError("analyse_impact.G", G.shape, f"(3,3) or ({n_all},3,3) finite kernel tensors")
    auto = isinstance(crack_count, str) and crack_count == "auto"
    N = 0 if auto else int(crack_count)
    if not auto and (N != crack_count or not 1 <= N <= MAX_CRACKS):
        raise ConfigError("cracks", crack_count, f"an integer 1..{MAX_CRACKS} or 'auto'")
    B = float(thickness)
    if not (math.isfinite(B) and B > 0.0):
        raise ConfigError("thickness", thickness, "> 0 m and finite")
    if field not in FIELDS:
        raise ConfigError("analyse_impact.field", field, ", ".join(FIELDS))
    if gradient not in GRADIENTS:
        raise ConfigError("analyse_impact.gradient", gradient, ", ".join(GRADIENTS))
    if correction not in CORRECTIONS:  # True == 1, False == 0
        raise ConfigError("analyse_impact.correction", correction, "0/False (plain), 1/True (Bonet-Lok), 2 (quadratic)")
    C = np.asarray(material.stiffness, dtype=np.float64)
    sigma_t = float(material.tensile_strength)
    Gc = float(material.toughness)

    # 1. contact
    E1, nu1 = effective_isotropic(C)
    hz = hertz_impact(impact.m1, impact.m2, impact.R1, impact.R2, E1, nu1, impact.E2, impact.nu2, impact.speed)
    F = hz.force
    P, n = impact.point, impact.normal

    # 2. nearest particle, its kernel, the analysed set N_p (Algorithm 1, lines 1-6)
    d = x - P
    dist2 = np.einsum("ij,ij->i", d, d)
    nearest = int(np.argmin(dist2))
    GP = np.array(G[nearest])
    if np.linalg.eigvalsh(GP)[0] <= 0.0:
        raise ConfigError(f"analyse_impact.G[{nearest}]", GP.tolist(), "symmetric positive definite")
    rho = float(1.0 / np.linalg.eigvalsh(GP)[0])
    cand = np.flatnonzero(dist2 < rho * rho * (1.0 + 1e-12))
    qP = np.linalg.norm(d[cand] @ GP.T, axis=1)
    members = cand[qP < 1.0]
    m = members.size

    e1 = _reference_direction(GP, n, impact.reference)
    frame = np.stack([e1, np.cross(n, e1), n])

    V_near = float(volume[nearest])
    r_near = float(np.cbrt(3.0 * V_near / (4.0 * math.pi)))
    depth_all = d @ n
    inplane2 = np.maximum(dist2 - depth_all * depth_all, 0.0)
    # depth of the body below P: the column within one tet edge of the normal line, down to its first
    # gap wider than two tet edges of the particles beside it (a hollow body's far wall is not part
    # of the struck wall)
    e_near = tet_edge(V_near)
    col = np.flatnonzero((inplane2 < e_near * e_near) & (depth_all >= -r_near))
    z_mid = 0.0
    if col.size:
        order_z = np.argsort(depth_all[col], kind="stable")
        zc = depth_all[col][order_z]
        ec = np.cbrt(6.0 * math.sqrt(2.0) * volume[col][order_z])  # tet edges of the column
        gaps = np.flatnonzero(np.diff(zc) > 2.0 * np.maximum(ec[:-1], ec[1:]))
        z_far = float(zc[gaps[0]] if gaps.size else zc[-1])
        depth = z_far + r_near
        z_mid = 0.5 * (float(zc[0]) + z_far)  # mid-surface of the struck wall (centroid depths)
    else:
        depth, z_far = r_near, 0.0
    depth = max(depth, r_near)
    wall = _struck_wall(d, depth_all, volume, n, z_far, e_near)
    use = field
    if use == "auto":
        use = wall.kind(depth)
    beam = None
    e_body = 0.0
    Bf = min(B, depth) if use == "plate" else 0.0
    z_shift = np.array([0.0, 0.0, z_mid - 0.5 * Bf])  # plate field: zeta = z - z_mid
    Lp = 0.0
    if use == "plate":
        # support radius: that of a disc with the wall's mid-surface area (a pane: about its size)
        Lp = max(math.sqrt(wall.volume / (math.pi * Bf)), 2.0 * rho)
        e_body = plate_energy(E1, nu1, Bf, Lp)
    elif use == "beam":
        beam = wall.beam(E_along(C, wall.axis), nu1, impact.m1, impact.held, e_near)
        e_body = beam.energy()
    hz = series_impact(hz, e_body)
    F = hz.force
    ell = max(hz.radius_a, r_near)
    if auto:  # N from the struck wall's bending vs fracture energy (sph/structure.py, Vandenberghe 2013)
        h_wall = Bf if use == "plate" else min(B, depth)
        N = int(np.clip(round(star_crack_count(E1, h_wall, Gc, material.density, impact.speed)), 1, MAX_CRACKS))
    bis_ang = 2.0 * math.pi * np.arange(N) / N
    bis = np.cos(bis_ang)[:, None] * frame[0] + np.sin(bis_ang)[:, None] * frame[1]
    if use in ("plate", "beam"):
        # a wall that bends: G_P's kernel swept from P through the wall to its far face, so that the
        # bending tension on the far side is in the analysed set (Algorithm 1, lines 1-6)
        t_ax = np.clip(depth_all, 0.0, z_far)
        reach_c = rho + z_far
        cand = np.flatnonzero(dist2 < reach_c * reach_c * (1.0 + 1e-12))
        off = d[cand] - t_ax[cand, None] * n
        members = cand[np.linalg.norm(off @ GP.T, axis=1) < 1.0]
        m = members.size
    tim["select_ms"] = (clock() - t0) * 1e3

    # 3. neighbours of the members and the contact displacement at unit force
    t1 = clock()
    if m and gradient == "sph":
        Gm_rho = 1.0 / np.linalg.eigvalsh(G[members])[:, 0]
        reach = float(np.sqrt(dist2[members].max())) + float(Gm_rho.max())
        local = np.flatnonzero(dist2 < reach * reach * (1.0 + 1e-12))
        owner, nbr = neighbour_pairs(x, G, members, local)
        need = np.union1d(members, nbr)
    else:
        owner = nbr = np.zeros(0, dtype=np.int64)
        need = members
    u = np.zeros((n_all, 3))
    if need.size:
        loc = d[need] @ frame.T
        if use == "beam":
            u_loc = beam.displacement(wall.local(d[need])) @ wall.frame @ frame.T
        elif use == "plate":
            u_loc = plate_displacement(loc - z_shift, 1.0, E1, nu1, Bf, Lp, ell)
        else:
            u_loc = boussinesq_displacement(loc, 1.0, E1, nu1, ell)
        u[need] = u_loc @ frame  # local (e1, e2, n) components -> reference frame
    tim["field_ms"] = (clock() - t1) * 1e3

    # 4-5. per-member gradient, strain, stress, energy (unit force); groups
    t2 = clock()
    if gradient == "sph":
        grad, _ = sph_gradient(x, volume, G, u, members, owner, nbr, correction)
    elif use == "beam":
        grad = np.einsum("ai,mab,bj->mij", wall.frame, beam.gradient(wall.local(d[members])), wall.frame)
    elif use == "plate":
        lm = d[members] @ frame.T
        grad = np.einsum("ai,mab,bj->mij", frame, plate_gradient(lm - z_shift, 1.0, E1, nu1, Bf, Lp, ell), frame)
    else:
        lm = d[members] @ frame.T
        grad = np.einsum("ai,mab,bj->mij", frame, boussinesq_gradient(lm, 1.0, E1, nu1, ell), frame)
    eps = 0.5 * (grad + np.swapaxes(grad, 1, 2))
    ev = strain_to_voigt(eps)
    sv = ev @ C.T
    sig = stress_from_voigt(sv)
    U1 = 0.5 * volume[members] * np.einsum("mi,mi->m", ev, sv)  # J per N^2
    sig_plus = _tensile_part(sig)
    lm = d[members] @ frame.T
    theta = np.arctan2(lm[:, 1], lm[:, 0]) if m else np.zeros(0)
    sector = 2.0 * math.pi / N
    grp = (np.floor(np.mod(theta + 0.5 * sector, 2.0 * math.pi) / sector).astype(np.int64)) % N
    w = volume[members] * np.cos(theta - bis_ang[grp]) ** 2
    wsum = np.bincount(grp, weights=w, minlength=N)
    cnt = np.bincount(grp, minlength=N)
    safe = np.where(wsum > 0.0, wsum, 1.0)

    def gmean(a: np.ndarray) -> np.ndarray:
        flat = (w[:, None, None] * a).reshape(m, 9)
        sums = np.stack([np.bincount(grp, weights=flat[:, c], minlength=N) for c in range(9)], axis=1)
        return sums.reshape(N, 3, 3) / safe[:, None, None]

    g_grad = gmean(grad) * F
    g_eps = gmean(eps) * F
    g_sig = gmean(sig) * F
    T1 = gmean(sig_plus)
    # plane stress where the wall is thin: across a plate (its normal n), or across a thin body
    # struck on its edge (a coin on its rim: its thin in-plane axis), whose free faces carry no load;
    # a half-space field's tension along that axis would split the body into slices
    Pi = np.eye(3)
    if use == "plate":  # thin-plate theory (sigma_iz = 0); drops the out-of-plane noise too
        Pi = np.eye(3) - np.outer(n, n)
    elif use == "halfspace" and wall.width < SLENDER_WIDTH * wall.length:
        Pi = np.eye(3) - np.outer(wall.frame[1], wall.frame[1])
    T1 = Pi @ T1 @ Pi
    U_g = np.bincount(grp, weights=U1, minlength=N) * F * F if m else np.zeros(N)
    pvals = np.zeros((N, 3))
    pdirs = np.zeros((N, 3))
    for k in range(N):  # N groups (a handful): sph.eigen as the conventions ask
        vals, vecs = sym_eig3_np(T1[k])
        nk = vecs[:, 0]
        t_k = np.cross(n, bis[k])
        ref = float(np.dot(nk, t_k))
        if abs(ref) < 1e-12:
            ref = float(np.dot(nk, bis[k]))
        pvals[k] = vals * F
        pdirs[k] = -nk if ref < 0.0 else nk
    # Rankine is a point criterion: a group fires where the largest tensile principal stress of one
    # of its members exceeds the strength (the crack starts at the peak, on the far face of a bent
    # wall or at the edge of a Hertz contact); the group mean gives the crack's direction (line 16)
    member_plus = Pi @ sig_plus @ Pi
    lam = np.linalg.eigvalsh(member_plus)[:, -1] if m else np.zeros(0)
    peak1 = np.zeros(N)
    np.maximum.at(peak1, grp, lam)
    tpn = peak1  # Pa/N; F > 0: ImpactSpec requires speed > 0
    fired = (cnt > 0) & (wsum > 0.0) & (peak1 * F > sigma_t)
    tim["stress_ms"] = (clock() - t2) * 1e3

    # 6-8. crack regions, r_outer (Eq. 11), r_inner (U_limit)
    K = 0.5 * hz.m_eff * impact.speed**2
    U_tot = float(U_g.sum())
    scale = min(1.0, K / U_tot) if U_tot > 0.0 else 0.0
    U_av = U_g * scale
    S_ref = math.sqrt(3.0) / 4.0 * e_near**2
    L_body = float(np.sqrt(dist2.max()))
    r_lo, r_hi = rho, max(L_body, rho)
    r_out = np.where(fired, np.clip((hz.area / S_ref) * U_av / (Gc * B), r_lo, r_hi), 0.0)
    A_near = math.sqrt(3.0) * e_near**2
    u_lim = 0.5 * Gc * A_near / V_near  # each face it frees is half of a crack shared with a neighbour
    U_rel = float(U_av.sum())
    r_in = 0.0
    if U_rel > 0.0:
        X = (64.0 * math.pi * rho**9 * u_lim / (315.0 * U_rel)) ** (1.0 / 3.0)
        if X < rho * rho:
            r_in = math.sqrt(rho * rho - X)
    sides = np.zeros((N, 3))
    cracks: list[Crack] = []
    for k in np.flatnonzero(fired):
        mk = pdirs[k]
        side = None
        if N > 1:
            for cand_dir in (bis[k], n):
                s = cand_dir - np.dot(cand_dir, mk) * mk
                if np.linalg.norm(s) >= SIDE_MIN:
                    side = s / np.linalg.norm(s)
                    break
        if side is not None:
            sides[k] = side
        cracks.append(
            Crack(point=P, normal=mk, r_outer=float(r_out[k]), side=side, r_inner=r_in, source=f"impact.group{k}")
        )
    tim["cracks_ms"] = (clock() - t2) * 1e3 - tim["stress_ms"]
    elapsed = (clock() - t0) * 1e3
    return ImpactAnalysis(
        cracks=cracks,
        hertz=hz,
        field=use,
        E1=E1,
        nu1=nu1,
        nearest=nearest,
        kernel=GP,
        support_radius=rho,
        frame=frame,
        regularisation=ell,
        plate_thickness=Bf,
        plate_radius=Lp,
        body_energy=e_body,
        depth=depth,
        particles=members,
        pairs=int(owner.size),
        group=grp,
        theta=theta,
        bisector=bis,
        members=cnt,
        grad_u=g_grad,
        strain=g_eps,
        stress=g_sig,
        tension=T1 * F,
        principal_stress=pvals,
        principal_dir=pdirs,
        tension_per_newton=tpn,
        energy=U_g,
        energy_available=U_av,
        fired=fired,
        r_outer=r_out,
        side=sides,
        r_inner=r_in,
        u_limit=u_lim,
        kinetic_energy=K,
        tensile_strength=sigma_t,
        elapsed_ms=elapsed,
        timings=tim,
    )


def threshold_speed(analysis: ImpactAnalysis, impact: ImpactSpec | None = None) -> float:
    """Speed (m/s) at which the analysis' largest group tension reaches the tensile strength:
    F_th = sigma_t / max_g (peak tension / F), and the speed whose impact energy makes that force
    with the Hertz contact and the wall's compliance in series (sph/structure.py):
    1/2 m* v^2 = 2/5 F^(5/3) k_H^(-2/3) + E_1 F^2. Exact while the regularisation stays l = r_P
    (a <= r_P at that speed: the analysis is then linear in F); inf if no group has tension. The
    effective m*, R*, E* come from analysis.hertz (`impact` is accepted for symmetry with
    `hertz_cone_threshold` and not needed)."""
    s = float(np.max(analysis.tension_per_newton)) if analysis.tension_per_newton.size else 0.0
    if not s > 0.0:
        return math.inf
    hz = analysis.hertz
    F = analysis.tensile_strength / s
    v_hertz = speed_for_force(F, hz.m_eff, hz.R_eff, hz.E_eff)
    return math.sqrt(v_hertz**2 + 2.0 * analysis.body_energy * F * F / hz.m_eff)


def hertz_cone_threshold(material: Material, impact: ImpactSpec) -> float:
    """Speed (m/s) at which the classical Hertz tension (1 - 2 nu1)/3 p0 reaches the tensile strength
    (sph.contact.hertz_threshold_speed with the Hill-averaged (E1, nu1)): the cone-crack criterion of
    contact mechanics, v_th ~ sigma_t^(5/2), for comparison with `threshold_speed`."""
    E1, nu1 = effective_isotropic(material.stiffness)
    return hertz_threshold_speed(
        impact.m1, impact.m2, impact.R1, impact.R2, E1, nu1, impact.E2, impact.nu2, material.tensile_strength
    )


# ----------------------------------------------------------------------------- several materials


@dataclass(frozen=True)
class MaterialCrossing:
    """Where a crack region first reaches particles of another material (Sect. 6, Fig. 12)."""

    point: np.ndarray  # (3,) m: the other-material particle's centroid projected onto the crack plane
    particle: int  # index of that particle
    material: int  # its material id
    distance: float  # m: in-plane distance from the crack point


def material_crossings(
    x: np.ndarray,
    material_id: np.ndarray,
    crack: Crack,
    crack_material: int | None = None,
    band: float | np.ndarray | None = None,
    directions: int = 8,
) -> list[MaterialCrossing]:
    """Points where `crack` reaches particles of another material.

    A particle j is reached when its material differs from the crack's (`crack_material`, default:
    the material of the particle nearest to crack.point), its centroid lies within `band` (m) of the
    crack plane (default: the median nearest-neighbour distance of the particles within r_outer of
    the crack point) and its projection onto the plane lies in the crack region (half-disc or disc,
    geometry.cutting.in_region). The plane is split into `directions` equal angular sectors around
    the crack point; the nearest reached particle of each sector is returned, sorted by distance.
    The World restarts the analysis at these points with the other material's constants and kernel,
    and stops the crack at the first one (`stop_at_crossings`).
    """
    x = np.asarray(x, dtype=np.float64)
    mid = np.asarray(material_id).reshape(-1)
    if x.ndim != 2 or x.shape[1] != 3 or mid.shape != (x.shape[0],):
        raise ConfigError("material_crossings", (np.shape(x), np.shape(mid)), "x (N,3) and material_id (N,)")
    if x.shape[0] == 0:
        return []
    if crack_material is None:
        crack_material = int(mid[int(np.argmin(((x - crack.point) ** 2).sum(axis=1)))])
    if band is None:
        near = np.flatnonzero(((x - crack.point) ** 2).sum(axis=1) <= crack.r_outer**2)
        if near.size < 2:
            return []
        band = float(np.median(cKDTree(x).query(x[near], k=2)[0][:, 1]))
    dist = signed_distance(crack, x)
    cand = (mid != crack_material) & (np.abs(dist) <= band) & in_region(crack, x)
    idx = np.flatnonzero(cand)
    if idx.size == 0:
        return []
    proj = x[idx] - dist[idx, None] * crack.normal
    q = proj - crack.point
    r = np.linalg.norm(q, axis=1)
    helper = np.eye(3)[int(np.argmin(np.abs(crack.normal)))]
    a1 = helper - np.dot(helper, crack.normal) * crack.normal
    a1 /= np.linalg.norm(a1)
    a2 = np.cross(crack.normal, a1)
    ang = np.mod(np.arctan2(q @ a2, q @ a1), 2.0 * math.pi)
    sec = np.minimum((ang / (2.0 * math.pi / directions)).astype(np.int64), directions - 1)
    order = np.lexsort((idx, r, sec))  # per sector: nearest first, ties by index
    first = order[np.r_[True, sec[order][1:] != sec[order][:-1]]]
    first = first[np.lexsort((idx[first], r[first]))]
    return [
        MaterialCrossing(point=proj[k].copy(), particle=int(idx[k]), material=int(mid[idx[k]]), distance=float(r[k]))
        for k in first
    ]


def stop_at_crossings(crack: Crack, crossings: list[MaterialCrossing]) -> Crack:
    """The crack shortened to its first crossing (Sect. 6: a crack stops at another material)."""
    if not crossings:
        return crack
    r = max(min(c.distance for c in crossings), 1e-12)
    return Crack(point=crack.point, normal=crack.normal, r_outer=min(crack.r_outer, r), side=crack.side,
                 r_inner=min(crack.r_inner, r), source=crack.source)


__all__ = [
    "FIELDS",
    "ImpactAnalysis",
    "ImpactSpec",
    "MaterialCrossing",
    "analyse_impact",
    "hertz_cone_threshold",
    "material_crossings",
    "neighbour_pairs",
    "sph_gradient",
    "stop_at_crossings",
    "threshold_speed",
]
