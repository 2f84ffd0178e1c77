"""Mass properties of a rigid body from its tetrahedra (DESIGN.md 5 "Rigid bodies").

Exact integrals over each tet (constant density per tet), not point masses:

- mass            m_t = rho_t V_t (given per tet; the body's mass is their exactly rounded sum, math.fsum)
- first moment    m_t c_t with c_t = (v0 + v1 + v2 + v3) / 4
- second moment   C_t = int_T rho x x^T dV = m_t / 20 * (sum_k v_k v_k^T + s s^T),  s = sum_k v_k
  (the covariance form of the canonical tet, Blow & Binstock 2004; it equals Tonon 2004's closed
  form: for the unit tet (0, e1, e2, e3) it gives (1/120) [[2,1,1],[1,2,1],[1,1,2]]).
- inertia about the centre of mass: C = sum_t C_t - m c c^T, I = tr(C) Id - C.

Vertices are shifted by a reference point near the centre first so that large coordinates do not
cancel digits.

Inertia floor (documented in docs/notes_rigid.md): a needle-like or flat-thin fragment has one
principal moment near zero; a contact impulse then spins it up without bound (w = I^-1 L). Every
principal moment is raised to at least

    I_floor = INERTIA_FLOOR_RATIO * (2/5) m r_eq^2,   r_eq = (3 V / 4 pi)^(1/3),

i.e. a fraction of the moment of a ball of the same volume and mass. With the default ratio 0.1 a
cube (I = 0.167 m a^2), a single regular tet (0.05 m a^2) and any fragment with aspect ratio below
about 1:10 are untouched; a 100:1 needle is raised. A floored body no longer conserves angular
momentum exactly when it is split off (the floor adds inertia); `MassProperties.floored` tells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import MeshError
from geometry.tetmesh import signed_volumes
from rigid.quat import quat_from_matrix

INERTIA_FLOOR_RATIO = 0.1  # -: principal moments >= ratio * (2/5) m r_eq^2 (ball of equal volume)


@dataclass
class MassProperties:
    """Mass, centre of mass and inertia of one body, in the reference frame."""

    mass: float  # kg: sum of the tet masses
    volume: float  # m^3: sum of the tet volumes
    com: np.ndarray  # (3,) m: centre of mass in reference coordinates (body_ref_com)
    inertia: np.ndarray  # (3, 3) kg m^2: about the COM, reference axes, after the floor
    inertia_exact: np.ndarray  # (3, 3) kg m^2: the exact tet integral, before the floor
    principal_moments: np.ndarray  # (3,) kg m^2: eigenvalues of `inertia`, ascending
    principal_axes: np.ndarray  # (3, 3): columns are the principal axes (det +1), reference frame
    floored: bool  # True when the floor raised a principal moment

    @property
    def inv_inertia(self) -> np.ndarray:
        """(3, 3) 1/(kg m^2): body-frame inverse inertia about the COM."""
        a = self.principal_axes
        return a @ np.diag(1.0 / self.principal_moments) @ a.T

    @property
    def principal_q(self) -> np.ndarray:
        """(4,) w-x-y-z: rotation from the principal frame to the body (reference) frame."""
        return quat_from_matrix(self.principal_axes)


def tet_second_moments(rest_verts: np.ndarray, masses: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(T, 3, 3) kg m^2: int rho (x - o)(x - o)^T dV of each tet (exact for constant density).

    The six distinct entries, each over contiguous coordinate columns and mirrored: the same
    operations in the same order per entry as the (T, 3, 3) outer products, so the same bits, 3x faster
    for a pot's fragments (tests/unit/test_rigid_mass.py)."""
    v = np.asarray(rest_verts, dtype=np.float64) - origin
    col = np.ascontiguousarray(v.transpose(1, 2, 0))  # (4, 3, T): vertex k's coordinate a over the tets
    s = col.sum(axis=0)  # (3, T): sum_k v_k
    w = np.asarray(masses, dtype=np.float64) / 20.0
    out = np.empty((len(v), 3, 3))
    for a in range(3):
        for b in range(a, 3):
            e = col[0, a] * col[0, b]  # sum_k v_k v_k^T, vertex by vertex, then + s s^T
            for k in range(1, 4):
                e += col[k, a] * col[k, b]
            e += s[a] * s[b]
            out[:, a, b] = out[:, b, a] = w * e
    return out


def inertia_floor(mass: float, volume: float, ratio: float = INERTIA_FLOOR_RATIO) -> float:
    """kg m^2: the smallest principal moment allowed (see the module docstring)."""
    r_eq = (3.0 * volume / (4.0 * math.pi)) ** (1.0 / 3.0)
    return ratio * 0.4 * mass * r_eq * r_eq


def mass_properties(
    rest_verts: np.ndarray, masses: np.ndarray, floor_ratio: float = INERTIA_FLOOR_RATIO, source: str = "body"
) -> MassProperties:
    """Exact mass properties of a body made of tets.

    rest_verts: (T, 4, 3) m, reference-frame vertices (positively oriented); masses: (T,) kg.
    Raises MeshError for an empty set, non-positive total mass or non-finite input.
    """
    verts = np.asarray(rest_verts, dtype=np.float64).reshape(-1, 4, 3)
    m = np.asarray(masses, dtype=np.float64).reshape(-1)
    if len(verts) == 0 or len(verts) != len(m):
        raise MeshError(
            source,
            "mass properties need at least one tet and one mass per tet",
            f"{len(verts)} tets, {len(m)} masses",
        )
    if not (np.all(np.isfinite(verts)) and np.all(np.isfinite(m))):
        raise MeshError(source, "non-finite tet vertices or masses")
    if np.any(m <= 0.0):
        raise MeshError(source, "tets with non-positive mass", f"{int((m <= 0).sum())} of {len(m)}")
    total = math.fsum(m.tolist())
    vol = math.fsum(np.abs(signed_volumes(verts)).tolist())
    centroids = (((verts[:, 0] + verts[:, 1]) + verts[:, 2]) + verts[:, 3]) / 4.0  # mean(axis=1)'s bits, 4x faster
    origin = centroids.mean(axis=0)
    first = (m[:, None] * (centroids - origin)).sum(axis=0)
    d = first / total
    com = origin + d
    c = tet_second_moments(verts, m, origin).sum(axis=0) - total * np.outer(d, d)
    c = 0.5 * (c + c.T)
    exact = np.trace(c) * np.eye(3) - c
    lam, axes = np.linalg.eigh(exact)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    floor = inertia_floor(total, vol, floor_ratio)
    floored = bool(np.any(lam < floor))
    lam_f = np.maximum(lam, floor)
    inertia = exact if not floored else axes @ np.diag(lam_f) @ axes.T
    return MassProperties(
        mass=total,
        volume=vol,
        com=com,
        inertia=inertia,
        inertia_exact=exact,
        principal_moments=lam_f,
        principal_axes=axes,
        floored=floored,
    )


def static_mass_properties(com) -> MassProperties:
    """Placeholder mass properties for a static (immovable) body: infinite mass and inertia."""
    com = np.asarray(com, dtype=np.float64).reshape(3)
    inf = np.full(3, np.inf)
    return MassProperties(
        mass=math.inf,
        volume=0.0,
        com=com,
        inertia=np.diag(inf),
        inertia_exact=np.diag(inf),
        principal_moments=inf,
        principal_axes=np.eye(3),
        floored=False,
    )
