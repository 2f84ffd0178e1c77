"""The steps of the paper's Algorithm 1 (Sect. 4.2, Fig. 2), each named after what the paper calls
it; `sph.cracks.analyse_impact` runs them in order; sph/cracks.py's module docstring explains each step,
the equations and the documented departures from the paper. Host numpy, float64, vectorised (10-500 rows).

    neighbourhood      lines 1-6   G_P of the particle nearest to P, the analysed set N_p, the wall under P
    wall_field         line 7      which contact field the struck wall carries (half-space, plate, beam)
    swept_members      lines 1-6   N_p swept through a wall that bends (its far-side tension is seen)
    displacement       line 7      the contact displacement on the members and their SPH neighbours
    member_state       13-14       per member: grad u (Eq. 7), strain (Eq. 1), stress, energy (Eq. 8)
    angular_groups     10-11       N sectors about the normal (a documented departure: radial cracks)
    group_state        13-14       per group: weighted means of grad u, strain, stress, tension; energy
    rankine_test       15-16       which groups fire (point criterion) and their crack normals
    crack_radii        17 (Eq. 11) r_outer from the group energy and the contact area
    onset_energy       17          the energy held when the peak tension reaches the strength
    plug_energy        17          what a striker that perforates a wall leaves in it (Recht & Ipson)
    shatter_level      17          where the released energy exceeds U_limit (r_inner, per particle size)
    thin_axis          6           the direction a crack runs through whole (a thin wall's)
    crack_sides        6           the side of each fired group's half-disc
    arrest_lengths     17          how far fracture mechanics drives each crack (beyond the paper)
    crack_regions      output      the half-disc crack of each fired group
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.arrays import cross3
from core.errors import ConfigError
from geometry.cutting import Crack, ShatterField
from geometry.particles import tet_edge
from sph.cleavage import Cleavage, equivalent_tension, opens_on_plane, tension_across
from sph.contact import boussinesq_displacement, boussinesq_gradient, plate_displacement, plate_gradient
from sph.eigen import sym_eig3_np
from sph.gradient import neighbour_pairs, sph_gradient
from sph.materials import strain_to_voigt, stress_from_voigt
from sph.struck_wall import SLENDER_WIDTH, E_along, StruckWall, struck_wall
from sph.structure import plate_energy

SIDE_MIN = 0.1  # |side projection| below which the side falls back (angle to the normal < ~6 deg)
ISO_TOL = 1e-6  # relative difference of in-plane kernel lengths below which G_P has no in-plane axis


def reference_direction(GP: np.ndarray, n: np.ndarray, reference: np.ndarray | None) -> np.ndarray:
    """e1 of the analysis frame (module doc of sph/cracks.py, step 4): the given reference, else the
    longest in-plane axis of G_P, else the coordinate axis least aligned with n; sign made positive."""
    if reference is not None:
        e1 = reference - np.dot(reference, n) * n
    else:
        axes = np.eye(3)
        helper = axes[int(np.argmin(np.abs(n)))]  # least aligned with n (argmin: lowest index on ties)
        t1 = helper - np.dot(helper, n) * n
        t1 /= np.linalg.norm(t1)
        t2 = cross3(n, t1)
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
class Neighbourhood:
    """Algorithm 1, lines 1-6: the analysed set N_p around P and the wall under P."""

    d: np.ndarray  # (N,3) m: x - P of every particle
    dist2: np.ndarray  # (N,) m^2: |x - P|^2
    depth_all: np.ndarray  # (N,) m: (x - P) . n
    nearest: int  # the particle nearest to P
    kernel: np.ndarray  # (3,3) 1/m: G_P
    rho: float  # m: support radius of G_P
    members: np.ndarray  # (M,) int: N_p
    frame: np.ndarray  # (3,3): rows e1, e2, n
    V_near: float  # m^3: volume of the nearest particle
    r_near: float  # m: radius of its volume sphere
    e_near: float  # m: its regular-tet edge
    depth: float  # m: d_n, depth of the struck wall below P
    z_far: float  # m: centroid depth of the wall's far layer
    z_mid: float  # m: depth of the wall's mid-surface
    wall: StruckWall


def neighbourhood(x: np.ndarray, volume: np.ndarray, G: np.ndarray, P: np.ndarray, n: np.ndarray,
                  reference: np.ndarray | None) -> Neighbourhood:
    """Lines 1-6: the kernel G_P of the particle nearest to P, the members |G_P (x - P)| < 1, and the
    depth of the wall under P (the column within one tet edge of the normal line, down to its first
    gap wider than two tet edges: a hollow body's far wall is not part of the struck wall)."""
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
    e1 = reference_direction(GP, n, reference)
    frame = np.stack([e1, cross3(n, e1), n])
    V_near = float(volume[nearest])
    r_near = float(np.cbrt(3.0 * V_near / (4.0 * math.pi)))
    depth_all = d @ n
    inplane2 = np.maximum(dist2 - depth_all * depth_all, 0.0)
    e_near = tet_edge(V_near)
    col = np.flatnonzero((inplane2 < e_near * e_near) & (depth_all >= -r_near))
    z_mid = 0.0
    if col.size:
        order_z = np.argsort(depth_all[col], kind="stable")
        zc = depth_all[col][order_z]
        ec = tet_edge(volume[col][order_z])  # tet edges of the column
        gaps = np.flatnonzero(np.diff(zc) > 2.0 * np.maximum(ec[:-1], ec[1:]))
        z_far = float(zc[gaps[0]] if gaps.size else zc[-1])
        depth = z_far + r_near
        z_mid = 0.5 * (float(zc[0]) + z_far)  # mid-surface of the struck wall (centroid depths)
    else:
        depth, z_far = r_near, 0.0
    depth = max(depth, r_near)
    wall = struck_wall(d, depth_all, volume, n, z_far, e_near)
    return Neighbourhood(d, dist2, depth_all, nearest, GP, rho, members, frame, V_near, r_near, e_near, depth,
                         z_far, z_mid, wall)


@dataclass
class WallField:
    """Line 7's contact field: which model the struck wall carries and its parameters."""

    kind: str  # 'halfspace', 'plate' or 'beam'
    plate_thickness: float  # m: B_f (0 unless a plate)
    plate_radius: float  # m: support radius L of the plate (0 unless a plate)
    z_shift: np.ndarray  # (3,) m: plate coordinates zeta = z - z_mid
    body_energy: float  # J/N^2: the wall's compliance E_1, in series with Hertz (0: rigid backing)
    beam: object  # sph.structure.Beam or None


def wall_field(nb: Neighbourhood, field: str, B: float, E1: float, nu1: float, C: np.ndarray, m1: float,
               held: bool) -> WallField:
    """Step 3 of the module doc: the field the wall carries ('auto': from the StruckWall) and its
    compliance. A plate's thickness is min(B, d_n), its support radius that of a disc of the wall's
    mid-surface area (at least 2 rho_P); a beam's axial modulus comes from the full stiffness."""
    use = nb.wall.kind(nb.depth) if field == "auto" else field
    Bf = min(B, nb.depth) if use == "plate" else 0.0
    z_shift = np.array([0.0, 0.0, nb.z_mid - 0.5 * Bf])
    Lp, e_body, beam = 0.0, 0.0, None
    if use == "plate":
        Lp = max(math.sqrt(nb.wall.volume / (math.pi * Bf)), 2.0 * nb.rho)
        e_body = plate_energy(E1, nu1, Bf, Lp)
    elif use == "beam":
        beam = nb.wall.beam(E_along(C, nb.wall.axis), nu1, m1, held, nb.e_near)
        e_body = beam.energy()
    return WallField(use, Bf, Lp, z_shift, e_body, beam)


def swept_members(nb: Neighbourhood, n: np.ndarray) -> np.ndarray:
    """Lines 1-6 for a wall that bends: G_P's kernel swept from P through the wall to its far face,
    so that the bending tension on the far side is in the analysed set."""
    t_ax = np.clip(nb.depth_all, 0.0, nb.z_far)
    reach_c = nb.rho + nb.z_far
    cand = np.flatnonzero(nb.dist2 < reach_c * reach_c * (1.0 + 1e-12))
    off = nb.d[cand] - t_ax[cand, None] * n
    return cand[np.linalg.norm(off @ nb.kernel.T, axis=1) < 1.0]


def _field_displacement(wf: WallField, wall: StruckWall, d: np.ndarray, frame: np.ndarray, E1: float,
                        nu1: float, ell: float) -> np.ndarray:
    """(K,3) m/N: the contact field's displacement at offsets d from P, reference frame."""
    loc = d @ frame.T
    if wf.kind == "beam":
        u_loc = wf.beam.displacement(wall.local(d)) @ wall.frame @ frame.T
    elif wf.kind == "plate":
        u_loc = plate_displacement(loc - wf.z_shift, 1.0, E1, nu1, wf.plate_thickness, wf.plate_radius, ell)
    else:
        u_loc = boussinesq_displacement(loc, 1.0, E1, nu1, ell)
    return u_loc @ frame  # local (e1, e2, n) components -> reference frame


def _field_gradient(wf: WallField, wall: StruckWall, d: np.ndarray, frame: np.ndarray, E1: float, nu1: float,
                    ell: float) -> np.ndarray:
    """(M,3,3) 1/N: the contact field's exact displacement gradient at offsets d (the reference)."""
    if wf.kind == "beam":
        return np.einsum("ai,mab,bj->mij", wall.frame, wf.beam.gradient(wall.local(d)), wall.frame)
    lm = d @ frame.T
    if wf.kind == "plate":
        g = plate_gradient(lm - wf.z_shift, 1.0, E1, nu1, wf.plate_thickness, wf.plate_radius, ell)
    else:
        g = boussinesq_gradient(lm, 1.0, E1, nu1, ell)
    return np.einsum("ai,mab,bj->mij", frame, g, frame)


def displacement(x: np.ndarray, G: np.ndarray, nb: Neighbourhood, members: np.ndarray, wf: WallField, E1: float,
                 nu1: float, ell: float, gradient: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Line 7 ("virtual particles"): every member and every SPH neighbour of a member gets the
    contact displacement at unit force. Returns (u (N,3) m/N, pair owner, pair neighbour)."""
    if members.size and gradient == "sph":
        Gm_rho = 1.0 / np.linalg.eigvalsh(G[members])[:, 0]
        reach = float(np.sqrt(nb.dist2[members].max())) + float(Gm_rho.max())
        local = np.flatnonzero(nb.dist2 < reach * reach * (1.0 + 1e-12))
        owner, nbr = neighbour_pairs(x, G, members, local)
        need = np.flatnonzero(np.bincount(np.concatenate([members, nbr]), minlength=x.shape[0]))  # = union1d
    else:
        owner = nbr = np.zeros(0, dtype=np.int64)
        need = members
    u = np.zeros((x.shape[0], 3))
    if need.size:
        u[need] = _field_displacement(wf, nb.wall, nb.d[need], nb.frame, E1, nu1, ell)
    return u, owner, nbr


def tensile_part(sig: np.ndarray) -> np.ndarray:
    """(M,3,3) sigma^+ = sum_k max(s_k, 0) v_k v_k^T (LAPACK eigh, vectorised; exact for symmetric input)."""
    if sig.shape[0] == 0:
        return sig.copy()
    w, v = np.linalg.eigh(sig)
    return np.einsum("mik,mk,mjk->mij", v, np.maximum(w, 0.0), v)


def hooke(grad: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 1 and C eps for displacement gradients (M,3,3): (strain (M,3,3), strain and stress in Voigt
    form (M,6))."""
    eps = 0.5 * (grad + np.swapaxes(grad, 1, 2))
    ev = strain_to_voigt(eps)
    return eps, ev, ev @ C.T


@dataclass
class MemberState:
    """Lines 13-14 per member, at unit force (N = 1)."""

    grad: np.ndarray  # (M,3,3) 1/N: displacement gradient (Eq. 7)
    strain: np.ndarray  # (M,3,3) 1/N: small strain (Eq. 1)
    stress: np.ndarray  # (M,3,3) Pa/N: C eps
    tension: np.ndarray  # (M,3,3) Pa/N: tensile part sigma^+
    energy: np.ndarray  # (M,) J/N^2: U_i = V_i/2 eps : sigma (Eq. 8)


def member_state(x, volume, G, u, nb: Neighbourhood, members, owner, nbr, wf: WallField, C, E1, nu1, ell,
                 gradient: str, correction: int) -> MemberState:
    """Eq. 7 (on the particles, or the field's exact gradient), Eq. 1 and Eq. 8 at every member."""
    if gradient == "sph":
        grad, _ = sph_gradient(x, volume, G, u, members, owner, nbr, correction)
    else:
        grad = _field_gradient(wf, nb.wall, nb.d[members], nb.frame, E1, nu1, ell)
    eps, ev, sv = hooke(grad, C)
    energy = 0.5 * volume[members] * np.einsum("mi,mi->m", ev, sv)
    sig = stress_from_voigt(sv)
    return MemberState(grad, eps, sig, tensile_part(sig), energy)


@dataclass
class Groups:
    """Lines 10-11: member i in sector k about n, centred on the bisector b_k."""

    theta: np.ndarray  # (M,) rad: angle of (x_i - P) about n from e1
    group: np.ndarray  # (M,) int
    weight: np.ndarray  # (M,) m^3: V_i cos^2(theta_i - theta_k), members near the bisector count most
    weight_sum: np.ndarray  # (N,) m^3
    count: np.ndarray  # (N,) int: members per group
    angle: np.ndarray  # (N,) rad: bisector angles
    bisector: np.ndarray  # (N,3)


def angular_groups(nb: Neighbourhood, members: np.ndarray, volume: np.ndarray, N: int) -> Groups:
    """Lines 10-11 as sectors: k = floor(((theta_i + pi/N) mod 2 pi) / (2 pi/N))."""
    ang = 2.0 * math.pi * np.arange(N) / N
    bis = np.cos(ang)[:, None] * nb.frame[0] + np.sin(ang)[:, None] * nb.frame[1]
    lm = nb.d[members] @ nb.frame.T
    theta = np.arctan2(lm[:, 1], lm[:, 0]) if members.size else np.zeros(0)
    sector = 2.0 * math.pi / N
    grp = (np.floor(np.mod(theta + 0.5 * sector, 2.0 * math.pi) / sector).astype(np.int64)) % N
    w = volume[members] * np.cos(theta - ang[grp]) ** 2
    wsum = np.bincount(grp, weights=w, minlength=N)
    cnt = np.bincount(grp, minlength=N)
    return Groups(theta, grp, w, wsum, cnt, ang, bis)


def thin_axis(kind: str, wall: StruckWall, n: np.ndarray) -> np.ndarray | None:
    """(3,) the direction across which the struck wall is thin, or None for a thick body: a plate's
    normal n; a beam's or an edge-struck thin body's short in-plane axis (the disc struck on its rim)."""
    if kind == "plate":
        return n
    if kind == "beam" or (kind == "halfspace" and wall.width < SLENDER_WIDTH * wall.length):
        return wall.frame[1]
    return None


def plane_stress(kind: str, thin: np.ndarray | None) -> np.ndarray:
    """(3,3) projector onto the loaded directions where the wall is thin across `thin` (`thin_axis`: a
    plate's n, a thin body struck on its edge: its thin in-plane axis); the identity otherwise (a beam
    has its own section stress)."""
    t = None if kind == "beam" else thin
    return np.eye(3) if t is None else np.eye(3) - np.outer(t, t)


def group_mean(values: np.ndarray, gr: Groups, N: int) -> np.ndarray:
    """(N, ...) the groups' weighted means (weights gr.weight) of per-member values (M, ...)."""
    if values.shape[0] == 0:
        return np.zeros((N, *values.shape[1:]))
    flat = (gr.weight.reshape(-1, *([1] * (values.ndim - 1))) * values).reshape(values.shape[0], -1)
    sums = np.stack([np.bincount(gr.group, weights=flat[:, c], minlength=N) for c in range(flat.shape[1])], axis=1)
    safe = np.where(gr.weight_sum > 0.0, gr.weight_sum, 1.0)
    return (sums / safe[:, None]).reshape(N, *values.shape[1:])


def group_state(ms: MemberState, gr: Groups, N: int, F: float, Pi: np.ndarray) -> dict:
    """Lines 13-14 per group: the weighted means of grad u, strain, stress (at force F) and of the
    tensile stress per newton T_g (plane stress applied), and U_g = sum of the members' energies."""
    energy = np.bincount(gr.group, weights=ms.energy, minlength=N) * F * F if gr.group.size else np.zeros(N)
    return dict(grad_u=group_mean(ms.grad, gr, N) * F, strain=group_mean(ms.strain, gr, N) * F,
                stress=group_mean(ms.stress, gr, N) * F, tension_per_newton=Pi @ group_mean(ms.tension, gr, N) @ Pi,
                energy=energy)


def rankine_test(ms: MemberState, gr: Groups, T1: np.ndarray, n: np.ndarray, N: int, F: float, sigma_t: float,
                 Pi: np.ndarray, cleavage: Cleavage | None = None) -> tuple[np.ndarray, ...]:
    """Lines 15-16: a group fires where the largest tensile principal stress of one of its members
    exceeds the strength (the crack starts at the peak); its crack normal is the eigenvector of the
    largest principal value of the group's mean tension T_g, or the weak planes' normal where T_g
    uses more of their strength (sph.cleavage). Returns (principal values (N,3) Pa, normals (N,3),
    peak member tension per newton (N,) Pa/N, as the equivalent bulk tension, fired (N,))."""
    across = tension_across(Pi @ ms.stress @ Pi, cleavage) if cleavage is not None else None
    across_mean = group_mean(across, gr, N) if cleavage is not None else np.zeros(N)
    pvals = np.zeros((N, 3))
    pdirs = np.zeros((N, 3))
    for k in range(N):  # N groups (a handful): sph.eigen as the conventions ask
        vals, vecs = sym_eig3_np(T1[k])
        nk = cleavage.normal if opens_on_plane(across_mean[k], vals[0], cleavage, sigma_t) else vecs[:, 0]
        t_k = cross3(n, gr.bisector[k])
        ref = float(np.dot(nk, t_k))
        if abs(ref) < 1e-12:
            ref = float(np.dot(nk, gr.bisector[k]))
        pvals[k] = vals * F
        pdirs[k] = -nk if ref < 0.0 else nk
    bulk = np.linalg.eigvalsh(Pi @ ms.tension @ Pi)[:, -1] if gr.group.size else np.zeros(0)
    peak = np.zeros(N)
    np.maximum.at(peak, gr.group, equivalent_tension(bulk, across, cleavage, sigma_t))
    fired = (gr.count > 0) & (gr.weight_sum > 0.0) & (peak * F > sigma_t)
    return pvals, pdirs, peak, fired


def crack_radii(U_g: np.ndarray, fired: np.ndarray, K: float, area: float, e_near: float, Gc: float, B: float,
                rho: float, L_body: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 11 (a dimensionally consistent reading, module doc step 7): r_outer,g = (S / S_ref) U'_g /
    (G_c B), clamped to [rho_P, L_body], with U'_g = U_g min(1, K / sum U_g): the quasi-static field
    cannot store more than the impact's kinetic energy K. Returns (r_outer (N,) m, U'_g (N,) J)."""
    U_tot = float(U_g.sum())
    scale = min(1.0, K / U_tot) if U_tot > 0.0 else 0.0
    U_av = U_g * scale
    S_ref = math.sqrt(3.0) / 4.0 * e_near**2  # the nearest particle's tet face
    r_out = np.where(fired, np.clip((area / S_ref) * U_av / (Gc * B), rho, max(L_body, rho)), 0.0)
    return r_out, U_av


ARREST_LENGTHS = 48  # crack lengths sampled from the regularisation length to the body's reach
ARREST_DEPTHS = 5  # depths through the wall at which the crack front's opening stress is read


def stress_intensity(a: np.ndarray, opening: np.ndarray) -> np.ndarray:
    """(L,) Pa m^0.5: K(a_j) = 2 sqrt(a_j / pi) int_0^a_j sigma(x) / sqrt(a_j^2 - x^2) dx for cracks of
    lengths a (ascending, m) opened by the stress sigma (Pa) given at the same distances: the weight
    function of a crack under symmetric loading (Tada, Paris and Irwin, The Stress Analysis of Cracks
    Handbook; sigma sqrt(pi a) for a uniform stress). sigma is taken constant on each interval between
    the distances (their mean; sigma(a_0) on [0, a_0]), where the weight integrates exactly to the
    difference of arcsin(x / a_j), so a stress concentrated near the crack's start is not missed."""
    edges = np.concatenate([[0.0], a])
    mean = np.concatenate([[opening[0]], 0.5 * (opening[1:] + opening[:-1])])
    arc = np.arcsin(np.minimum(edges[None, :] / a[:, None], 1.0))
    return 2.0 * np.sqrt(a / math.pi) * (np.diff(arc, axis=1) @ mean)


def arrest_lengths(wf: WallField, nb: Neighbourhood, C: np.ndarray, E1: float, nu1: float, ell: float,
                   Pi: np.ndarray, pdirs: np.ndarray, sides: np.ndarray, fired: np.ndarray, F: float, Gc: float,
                   L_body: float) -> np.ndarray:
    """Step 7 of the module doc of sph/cracks.py, (N,) m: how far each fired crack runs before linear
    elastic fracture mechanics arrests it. Along its side in its plane, the contact field at force F
    opens it with sigma(x) = m_k . sigma . m_k (tension only; the largest through the wall, plane
    stress applied), which gives a crack of length a its stress intensity K(a) (`stress_intensity`).
    It runs while K >= K_Ic = sqrt(E_m G_c) (E_m: Young's modulus across the crack plane, plane
    stress) and stops at the first length where K falls below. 0 where K(ell) < K_Ic or the group did
    not fire; the body's reach L_body where it never falls below."""
    out = np.zeros(len(fired))
    if not np.any(fired) or not F > 0.0 or not L_body > ell:
        return out
    a = np.geomspace(ell, L_body, ARREST_LENGTHS)
    depths = np.linspace(0.0, max(nb.z_far, 0.0), ARREST_DEPTHS)
    n = nb.frame[2]
    for k in np.flatnonzero(fired):
        m = pdirs[k]
        s = sides[k]
        if not np.any(s):  # a full disc: along the wall's tangent in the crack plane
            s = nb.frame[0] - np.dot(nb.frame[0], m) * m
            s = s if np.linalg.norm(s) >= SIDE_MIN else nb.frame[1] - np.dot(nb.frame[1], m) * m
            s = s / np.linalg.norm(s)
        d = (a[:, None, None] * s + depths[None, :, None] * n).reshape(-1, 3)
        grad = _field_gradient(wf, nb.wall, d, nb.frame, E1, nu1, ell)
        sig = Pi @ stress_from_voigt(hooke(grad, C)[2]) @ Pi
        opening = F * np.einsum("i,mij,j->m", m, sig, m).reshape(a.size, depths.size).max(axis=1)
        K_a = stress_intensity(a, np.maximum(opening, 0.0))
        below = np.flatnonzero(K_a < math.sqrt(E_along(C, m) * Gc))
        out[k] = a[-1] if below.size == 0 else (a[below[0] - 1] if below[0] > 0 else 0.0)
    return out


def run_lengths(r_eq11: np.ndarray, arrest: np.ndarray, U_av: np.ndarray, fired: np.ndarray, Gc: float, B: float,
                rho: float, L_body: float) -> np.ndarray:
    """(N,) m: r_outer = max(Eq. 11, the arrest length within the energy bound U'_g / (G_c B)), clamped
    to [rho_P, L_body] (sph/cracks.py step 7): Eq. 11 weighs the energy by the contact area, which
    leaves a light landing's crack shorter than a kernel; the fracture-mechanics length lets a crack
    that the field keeps driving run on, as long as the group's energy pays for its surface."""
    run = np.minimum(arrest, U_av / (Gc * B))
    return np.where(fired, np.clip(np.maximum(r_eq11, run), rho, max(L_body, rho)), 0.0)


def onset_energy(U_av: float, peak_tension: float, sigma_t: float) -> float:
    """J: the elastic energy the analysed neighbourhood holds when its peak tension reaches the
    strength (module doc of sph/cracks.py, step 8): the field is linear in F, so its energy scales as
    F^2: U_onset = U' min(1, (sigma_t / T_peak)^2). A brittle solid cannot store the quasi-static
    energy beyond that; once its cracks run, the rest of the blow stays in the bodies' motion."""
    if not peak_tension > 0.0:
        return U_av
    return U_av * min(1.0, (sigma_t / peak_tension) ** 2)


def plug_energy(m_striker: float, density: float, striker_radius: float, thickness: float, speed: float) -> float:
    """J: the kinetic energy lost when a striker punches a plug of its cross-section out of a wall
    (Recht & Ipson 1963, J. Appl. Mech. 30: 384, the plugging collision): the plug, of mass
    m_p = rho pi R_s^2 B, is taken up to the striker's speed in a perfectly inelastic collision,
    Delta K = 1/2 m_s m_p / (m_s + m_p) v^2 (m_s = inf: 1/2 m_p v^2). That energy goes into the
    wall around the plug, crushed and thrown out."""
    m_p = density * math.pi * striker_radius**2 * thickness
    m_red = m_p if math.isinf(m_striker) else m_striker * m_p / (m_striker + m_p)
    return 0.5 * m_red * speed**2


def material_weight(dist2: np.ndarray, volume: np.ndarray, rho: float) -> float:
    """-: the integral of the normalised poly6 kernel of support rho over the material inside it,
    sum_j V_j 315/(64 pi rho^9) (rho^2 - d_j^2)^3 (1 for a support filled with material; a thin wall
    fills a fraction of it); at least the kernel of the nearest particle alone."""
    w = np.clip(rho * rho - dist2, 0.0, None) ** 3 * (315.0 / (64.0 * math.pi * rho**9))
    return float(min(1.0, max((volume * w).sum(), 1e-12)))


def u_limit(Gc: float, edge: float, volume: float) -> float:
    """J/m^3: the energy density that frees a particle (a regular tet of `edge`, `volume`): G_c times
    half its surface (sqrt3 e^2) per volume; each face it frees is one side of a crack shared with a
    neighbour."""
    return 0.5 * Gc * math.sqrt(3.0) * edge**2 / volume


def shatter_level(U_rel: float, rho: float, Gc: float, e_near: float, V_near: float, weight: float = 1.0) -> float:
    """-: `level` of geometry.cutting.ShatterField (module doc step 8): the released energy U spread in
    the material as u(r) = 315/(64 pi h^9)(h^2 - r^2)^3 U / weight (h = rho_P; `weight`:
    `material_weight`) reaches the u_limit of a particle of edge e_near and volume V_near where
    (h^2 - r^2) / h^2 = level = (64 pi h^9 u_limit weight / (315 U))^(1/3) / h^2; inf for U = 0."""
    if not U_rel > 0.0:
        return math.inf
    u_lim = u_limit(Gc, e_near, V_near)
    return (64.0 * math.pi * rho**9 * u_lim * weight / (315.0 * U_rel)) ** (1.0 / 3.0) / (rho * rho)


def crack_sides(n: np.ndarray, gr: Groups, pdirs: np.ndarray, fired: np.ndarray, N: int,
                thin: np.ndarray | None = None) -> np.ndarray:
    """Step 6, (N,3): the side of each fired group's half-disc, its bisector projected onto the crack
    plane (the inward normal if the bisector is within ~6 degrees of the crack normal); zeros for a
    full disc (N = 1) or a group that did not fire. Where the wall is thin across `thin` (`thin_axis`),
    a crack runs through the whole thickness: the side has no component across it, so the half-disc
    holds every depth at P (a side tilted through a disc's thickness left an uncut ligament at P's
    face, and two groups with the same crack plane cut the same wall twice)."""
    sides = np.zeros((N, 3))
    if N == 1:
        return sides
    for k in np.flatnonzero(fired):
        mk = pdirs[k]
        across = None
        if thin is not None:
            t_in = thin - np.dot(thin, mk) * mk  # the thin direction within the crack plane
            across = t_in / np.linalg.norm(t_in) if np.linalg.norm(t_in) >= SIDE_MIN else None
        for cand_dir in (gr.bisector[k], n):
            s = cand_dir - np.dot(cand_dir, mk) * mk
            if across is not None:
                s = s - np.dot(s, across) * across
            if np.linalg.norm(s) >= SIDE_MIN:
                sides[k] = s / np.linalg.norm(s)
                break
    return sides


def crack_regions(P: np.ndarray, pdirs: np.ndarray, fired: np.ndarray, sides: np.ndarray, r_out: np.ndarray,
                  r_in: float, r_crush: float = 0.0, shatter: ShatterField | None = None) -> list[Crack]:
    """Output: a disc through P per fired group with its crack normal, radius and side (`crack_sides`;
    none: a full disc), carrying the contact's shatter zone."""
    return [Crack(point=P, normal=pdirs[k], r_outer=float(r_out[k]), side=sides[k] if np.any(sides[k]) else None,
                  r_inner=r_in, r_crush=r_crush, shatter=shatter, source=f"impact.group{k}")
            for k in np.flatnonzero(fired)]
