"""Crack generation at an impact: the paper's Algorithm 1 (Sect. 4.2, Fig. 2, Eq. 1, 7, 8, 11, U_limit).

`analyse_impact` runs one analysis on the host (numpy, float64; the neighbourhood is tens to a few
hundred particles, everything is vectorised, no Python loop per particle; Eq. 7's neighbour test and
sums are float64 Taichi kernels on the CPU backend, sph/gradient_kernels.py). Its steps are functions
of sph/algorithm1.py named after the paper's lines; the struck wall is sph/struck_wall.py, Eq. 7
is sph/gradient.py, cracks that reach another material are sph/crossings.py. The steps:

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
    rho_P = the analysed kernel's support radius, L_body = the largest distance from P to a particle's
    centroid plus its tet edge (the body's reach: a crack clamped to it severs the far end too).
    U'_g = U_g min(1, K / sum_g U_g), K = 1/2 m* v^2: the quasi-static field cannot store more than
    the kinetic energy the impact brings (the Hertz force assumes a rigid backing; a compliant body
    takes less). Beyond the paper: the crack also runs as far as linear elastic fracture mechanics
    drives it (`arrest_lengths`): along its side, the field's opening stress at force F gives
    K(a) = 2 sqrt(a/pi) int_0^a sigma(x) / sqrt(a^2 - x^2) dx, and the crack stops where K < K_Ic =
    sqrt(E_m G_c); r_outer = max(Eq. 11, min(arrest length, U'_g / (G_c B))). The weight S/S_ref
    leaves a light landing's crack shorter than a kernel although the bending field keeps K above
    K_Ic over the whole shard (docs/decisions.md, "Crack arrest"). Particle geometry is that of a
    regular tet of the particle's volume V:
    edge e = (6 sqrt2 V)^(1/3), face area sqrt3/4 e^2.
 8. U_limit, r_inner (Sect. 4.2, read with the poly6 kernel's cube). The energy that shatters:
    - the elastic energy the neighbourhood holds when its peak tension reaches the strength,
      U_onset = sum_g U'_g min(1, (sigma_t / T_peak)^2) (the field is linear in F, its energy
      quadratic): a brittle solid cannot store the quasi-static energy beyond that; once its
      cracks run, the rest of the blow stays in the bodies' motion (and breaks them again when they
      land: secondary fracture);
    - plus, where a striker punches a plug out of a wall (the plate field fired; a moving striker
      whose radius of curvature at the contact, at most its half-width, is below half the plate's
      radius and not above the wall's own R1) above the ballistic limit (`_with_plug`: the blow pays
      the onset energy, the plug's rim crack and the plugging loss, which pays the crushing), the
      plugging loss of Recht & Ipson (1963): 1/2 m_s m_p / (m_s + m_p) v^2, m_p = rho pi R_s^2 B.
      The plug radius r_plug = R_s is shattered whatever the energy (the striker goes through it).
    U is spread in the material as the energy density u(r) = 315/(64 pi h^9) (h^2 - r^2)^3 U / w,
    h = rho_P, w = sum_j V_j 315/(64 pi h^9) (h^2 - d_j^2)^3 the share of the kernel's integral
    that lies in the body (a thin wall fills a small part of the sphere). A particle shatters where
    u exceeds the energy density needed to free it completely, i.e. to create crack area equal to
    half its surface (each face it frees is one side of a crack it shares with a neighbour):
    u_limit = G_c A_P / (2 V_P) (regular tet: A = sqrt3 e^2).
    r_inner^2 = h^2 - (64 pi h^9 u_limit w / (315 U))^(1/3) when positive, else 0; at least r_plug.
    The core the adaptive model resolves finer: where u also frees grains of a quarter of the
    particle's volume (the level at which subdivision resolves a crack; u_limit ~ 1 / edge, so
    4^(1/3) u_limit), r_fine^2 = h^2 - 4^(1/9) (h^2 - r_inner^2); r_crush = max(r_plug, r_fine) is
    crushed into such grains in subdivision mode (geometry/pulverise.py), freed whole in basic mode.
    Both radii are those of the particle nearest to P: every particle is freed (crushed) by its own
    size, r_j^2 = h^2 (1 - level (e_near / e_j)^(1/3)) (geometry.cutting.ShatterField), so the small
    children a crack left around P need the higher energy density their u_limit asks, and what a
    blow frees never costs more than the energy it releases. Cracks carry the field, r_inner and
    r_crush only if at least one group fired. Why the onset energy and not the energy
    at the peak force: docs/notes_cracks.md section 4.

Validity: that of the contact models (sph/contact.py): linear elastic, small strain, quasi-static
impact; a normal impact (friction and the tangential speed are ignored); the contact point P lies
on the struck surface with n its inward normal.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from core.errors import ConfigError
from geometry.cutting import GRAINS_PER_PARTICLE, Crack, ShatterField
from geometry.particles import tet_edge
from sph import algorithm1 as alg
from sph.contact import HertzImpact, effective_isotropic, hertz_impact, hertz_threshold_speed, speed_for_force
from sph.crossings import MaterialCrossing, material_crossings, stop_at_crossings
from sph.gradient import CORRECTIONS, neighbour_pairs, sph_gradient
from sph.materials import Material
from sph.structure import series_impact, star_crack_count

FIELDS = ("auto", "halfspace", "plate", "beam")
GRADIENTS = ("sph", "analytic")  # Eq. 7 on the particles, or the field's exact gradient (reference)
MAX_CRACKS = 64  # crack_count limit (a sector narrower than ~6 degrees holds no particle)


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
    striker_radius: float | None = None  # m: the other body's half-width across n (None: R2; inf: none)
    reference: np.ndarray | None = None  # (3,) -: in-plane reference direction e1 (None: from the kernel)
    held: bool = False  # the struck body is held by the scene (static): a beam is supported at its ends
    thin: np.ndarray | None = None  # (3,) -: axis across which the wall is thin, if known (a crossing: the contact's)

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
        t = None if self.thin is None else np.asarray(self.thin, dtype=np.float64).reshape(-1)
        if t is not None and not (t.shape == (3,) and np.all(np.isfinite(t)) and np.linalg.norm(t) > 0.0):
            raise ConfigError("impact.thin", self.thin, "a finite non-zero 3-vector or None")
        self.thin = None if t is None else t / np.linalg.norm(t)
        if self.striker_radius is not None and not float(self.striker_radius) > 0.0:  # NaN fails too
            raise ConfigError("impact.striker_radius", self.striker_radius, "> 0 m (inf: no plug), or None for R2")
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
    arrest_length: np.ndarray  # (N,) m: where fracture mechanics stops the crack (step 7; 0: not fired)
    side: np.ndarray  # (N,3): half-disc side (zeros for a full disc or no crack)
    r_inner: float  # m: shatter radius (U_limit); attached to the cracks only when one fired
    shatter_energy: float  # J: the energy spread by U_limit (onset energy plus a plug's, step 8)
    r_plug: float  # m: radius of the plug a perforating striker punches out (0: none)
    r_crush: float  # m: radius crushed into quarter grains in subdivision mode (the plug and r_fine; step 8)
    u_limit: float  # J/m^3: shatter threshold energy density
    kinetic_energy: float  # J: 1/2 m* v^2
    tensile_strength: float  # Pa
    elapsed_ms: float  # ms: wall time of the analysis (time.perf_counter)
    timings: dict = field(default_factory=dict)  # ms per stage
    thin_axis: np.ndarray | None = None  # (3,) -: the axis across which the struck wall is thin (None: thick)

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
                    "arrest_length": float(self.arrest_length[k]),
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
            "r_plug": float(self.r_plug),
            "r_crush": float(self.r_crush),
            "shatter_energy": float(self.shatter_energy),
            "u_limit": float(self.u_limit),
            "kinetic_energy": float(self.kinetic_energy),
            "tensile_strength": float(self.tensile_strength),
            "elapsed_ms": float(self.elapsed_ms),
            "timings_ms": {k: float(v) for k, v in self.timings.items()},
        }


# ----------------------------------------------------------------------------- Algorithm 1


def _checked_inputs(x, volume, G, crack_count, thickness, correction, field_kind, gradient):
    """The arguments of analyse_impact as float64 arrays; ConfigError naming the first bad one."""
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
    if field_kind not in FIELDS:
        raise ConfigError("analyse_impact.field", field_kind, ", ".join(FIELDS))
    if gradient not in GRADIENTS:
        raise ConfigError("analyse_impact.gradient", gradient, ", ".join(GRADIENTS))
    if correction not in CORRECTIONS:  # True == 1, False == 0
        raise ConfigError("analyse_impact.correction", correction, "0/False (plain), 1/True (Bonet-Lok), 2 (quadratic)")
    return x, volume, G, (None if auto else N), B


def _plug_radius(impact: ImpactSpec, wf, fired: np.ndarray) -> float:
    """m: the radius of the plug a striker punches out of the struck wall (step 8), 0 for none. A plug
    needs a wall that bends (the plate field) and cracked, a moving striker, and wall around it to
    punch it out of. Its radius is the striker's radius of curvature R2 at the contact (a ball's
    radius; a fragment's edge or corner is sharp), at most the striker's half-width across the normal
    (ImpactSpec.striker_radius), and it must stay below half the plate's radius L. The wall
    must be at least as flat there as the striker (R1 >= R_s): a wall that meets the striker with an
    edge or a corner has that edge crushed, not a plug punched out. A collider, or a striker as
    wide as the wall, strikes the whole wall."""
    R_s = impact.R2 if impact.striker_radius is None else min(impact.R2, float(impact.striker_radius))
    if wf.kind != "plate" or not fired.any() or math.isinf(impact.m2) or not math.isfinite(R_s):
        return 0.0
    if impact.R1 < R_s:
        return 0.0
    return R_s if 0.0 < R_s < 0.5 * wf.plate_radius else 0.0


def _grain(nb) -> tuple[float, float]:
    """(edge m, volume m^3) of the grains the crushed core is made of: the nearest particle's tet split
    into GRAINS_PER_PARTICLE (geometry/pulverise.py), taken as regular tets of that volume."""
    return nb.e_near / GRAINS_PER_PARTICLE ** (1.0 / 3.0), nb.V_near / GRAINS_PER_PARTICLE


def _with_plug(U_onset: float, K: float, impact: ImpactSpec, wf, nb, fired: np.ndarray,
               material: Material) -> tuple[float, float]:
    """(shatter energy J, plug radius m) (step 8): the onset energy, plus the plugging loss where a
    plug forms (`_plug_radius`) and the blow is above the ballistic limit: K pays the onset energy,
    the plug's cylindrical crack (G_c 2 pi R B) and the plugging loss, and the plugging collision
    pays for crushing the plug into quarter tets (edge e / 4^(1/3)); else the striker is stopped or
    bounces and no plug forms."""
    r_plug = _plug_radius(impact, wf, fired)
    if r_plug == 0.0:
        return U_onset, 0.0
    Gc, B = float(material.toughness), wf.plate_thickness
    plug = alg.plug_energy(impact.m2, material.density, r_plug, B, impact.speed)
    rim = Gc * 2.0 * math.pi * r_plug * B
    crush = alg.u_limit(Gc, *_grain(nb)) * math.pi * r_plug**2 * B
    if K >= U_onset + rim + plug and plug >= crush:
        return U_onset + plug, r_plug
    return U_onset, 0.0


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
    """Algorithm 1 at the contact point (module doc; its steps are in sph/algorithm1.py). x (N,3) m
    reference-frame rest centroids of the struck body's alive particles, volume (N,) m^3, G (N,3,3)
    or (3,3) 1/m kernel tensors, material (stiffness, tensile_strength, toughness G_c), impact:
    ImpactSpec, crack_count N >= 1 or 'auto', thickness B (m, Eq. 11), correction: the gradient
    order of Eq. 7, field: 'auto', 'halfspace', 'plate' or 'beam'. Raises ConfigError on bad input."""
    clock = time.perf_counter
    t0 = clock()
    x, volume, G, N, B = _checked_inputs(x, volume, G, crack_count, thickness, correction, field, gradient)
    C = np.asarray(material.stiffness, dtype=np.float64)
    sigma_t, Gc = float(material.tensile_strength), float(material.toughness)
    P, n = impact.point, impact.normal
    # 1. contact (Hertz); 2. lines 1-6: G_P, N_p and the wall under P
    E1, nu1 = effective_isotropic(C)
    hz = hertz_impact(impact.m1, impact.m2, impact.R1, impact.R2, E1, nu1, impact.E2, impact.nu2, impact.speed)
    nb = alg.neighbourhood(x, volume, G, P, n, impact.reference)
    wf = alg.wall_field(nb, field, B, E1, nu1, C, impact.m1, impact.held)
    hz = series_impact(hz, wf.body_energy)  # the wall's compliance in series with the contact
    F, ell = hz.force, max(hz.radius_a, nb.r_near)  # ell: the field is not resolved below a particle
    if N is None:  # cracks = "auto": N from the wall's bending vs fracture energy (Vandenberghe 2013)
        h_wall = wf.plate_thickness if wf.kind == "plate" else min(B, nb.depth)
        N = int(np.clip(round(star_crack_count(E1, h_wall, Gc, material.density, impact.speed)), 1, MAX_CRACKS))
    members = alg.swept_members(nb, n) if wf.kind in ("plate", "beam") else nb.members
    tim = {"select_ms": (clock() - t0) * 1e3}
    # 3. line 7: the contact displacement on the members and their neighbours (unit force)
    t1 = clock()
    u, owner, nbr = alg.displacement(x, G, nb, members, wf, E1, nu1, ell, gradient)
    tim["field_ms"] = (clock() - t1) * 1e3
    # 4-5. lines 10-16: per-member strain, stress, energy; groups; Rankine
    t2 = clock()
    ms = alg.member_state(x, volume, G, u, nb, members, owner, nbr, wf, C, E1, nu1, ell, gradient, correction)
    gr = alg.angular_groups(nb, members, volume, N)
    thin = alg.thin_axis(wf.kind, nb.wall, n) if impact.thin is None else impact.thin
    Pi = alg.plane_stress(wf.kind, thin)
    gs = alg.group_state(ms, gr, N, F, Pi)
    pvals, pdirs, peak, fired = alg.rankine_test(ms, gr, gs["tension_per_newton"], n, N, F, sigma_t, Pi,
                                                 material.cleavage)
    tim["stress_ms"] = (clock() - t2) * 1e3
    # 6-8. line 17: r_outer (Eq. 11), r_inner (U_limit), the crack regions
    K = 0.5 * hz.m_eff * impact.speed**2
    # the body's reach from P: its farthest particle's centroid plus that particle's tet edge, so a
    # crack clamped to it cuts the links and tets at the body's far end too (not only up to centroids)
    L_body = float((np.sqrt(nb.dist2) + tet_edge(volume)).max())
    r_out, U_av = alg.crack_radii(gs["energy"], fired, K, hz.area, nb.e_near, Gc, B, nb.rho, L_body)
    U_sh = alg.onset_energy(float(U_av.sum()), float(peak.max(initial=0.0)) * F, sigma_t)
    U_sh, r_plug = _with_plug(U_sh, K, impact, wf, nb, fired, material)
    weight = alg.material_weight(nb.dist2, volume, nb.rho)
    # each particle is freed by its own u_limit (~ 1/edge), subdivision mode crushes it into quarter
    # grains where those break free too; r_inner, r_crush: for the particle nearest to P
    level = alg.shatter_level(U_sh, nb.rho, Gc, nb.e_near, nb.V_near, weight)
    shatter = ShatterField(support=nb.rho, level=level, edge=nb.e_near, r_plug=r_plug)
    r_in, r_crush = shatter.radius(nb.V_near), shatter.radius(nb.V_near, grains=True)
    u_lim = alg.u_limit(Gc, nb.e_near, nb.V_near)
    sides = alg.crack_sides(n, gr, pdirs, fired, N, thin)
    arrest = alg.arrest_lengths(wf, nb, C, E1, nu1, ell, Pi, pdirs, sides, fired, F, Gc, L_body)
    r_out = alg.run_lengths(r_out, arrest, U_av, fired, Gc, B, nb.rho, L_body)
    cracks = alg.crack_regions(P, pdirs, fired, sides, r_out, r_in, r_crush, shatter)
    tim["cracks_ms"] = (clock() - t2) * 1e3 - tim["stress_ms"]
    return ImpactAnalysis(
        cracks=cracks, hertz=hz, field=wf.kind, E1=E1, nu1=nu1, nearest=nb.nearest, kernel=nb.kernel,
        support_radius=nb.rho, frame=nb.frame, regularisation=ell, plate_thickness=wf.plate_thickness,
        plate_radius=wf.plate_radius, body_energy=wf.body_energy, depth=nb.depth, particles=members,
        pairs=int(owner.size), group=gr.group, theta=gr.theta, bisector=gr.bisector, members=gr.count,
        grad_u=gs["grad_u"], strain=gs["strain"], stress=gs["stress"], tension=gs["tension_per_newton"] * F,
        principal_stress=pvals, principal_dir=pdirs, tension_per_newton=peak, energy=gs["energy"],
        energy_available=U_av, fired=fired, r_outer=r_out, arrest_length=arrest, side=sides, r_inner=r_in,
        u_limit=u_lim, shatter_energy=U_sh, r_plug=r_plug, r_crush=r_crush,
        kinetic_energy=K, tensile_strength=sigma_t, elapsed_ms=(clock() - t0) * 1e3, timings=tim, thin_axis=thin,
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
    "tet_edge",
    "threshold_speed",
]
