"""The struck wall under an impact point: which part of a body carries a blow, and whether it bends
as a plate or a beam or acts as a half-space (Sect. 4.2; used by Algorithm 1, sph/cracks.py step 3).

The wall is the set of particles between the struck face and the wall's far face at depth d_n (a
hollow body's far wall excluded), with the principal in-plane axes of their volume-weighted spread.
A wall thinner than STRUCTURAL_DEPTH of its length bends: a beam when it is also narrow with a
compact section, else a plate; a thick body is a half-space. `E_along` gives the axial modulus of an
anisotropic beam from its full stiffness.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.arrays import cross3
from geometry.particles import tet_edge
from sph.structure import Beam

STRUCTURAL_DEPTH = 0.25  # depth / longest in-plane size of the struck wall below which it bends (plate, beam)
SLENDER_WIDTH = 0.35  # width / length of the struck wall below which it is a beam ...
SLENDER_DEPTH = 3.0  # ... when its width is also under this many depths (a compact section)


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


def struck_wall(d: np.ndarray, depth: np.ndarray, volume: np.ndarray, n: np.ndarray, z_far: float,
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
    T = np.stack([t1, cross3(n, t1)])
    w, vec = np.linalg.eigh(T @ cov @ T.T)
    a = T.T @ vec[:, 1]  # largest spread: the long axis
    k = int(np.argmax(np.abs(a) - 1e-12 * np.arange(3)))
    a = -a if a[k] < 0.0 else a
    frame = np.stack([a, cross3(n, a), n])
    e = tet_edge(v)
    length = float(np.ptp(q @ a)) + float(e.mean())
    width = float(np.ptp(q @ frame[1])) + float(e.mean())
    return StruckWall(x, v, x @ n, e, frame, length, width)


def E_along(C: np.ndarray, axis: np.ndarray) -> float:
    """Young's modulus (Pa) along a unit axis of the Voigt stiffness C: 1/E = v^T C^-1 v with
    v = (a_x^2, a_y^2, a_z^2, a_y a_z, a_x a_z, a_x a_y) (uniaxial stress along the axis)."""
    a = np.asarray(axis, dtype=np.float64)
    v = np.array([a[0] ** 2, a[1] ** 2, a[2] ** 2, a[1] * a[2], a[0] * a[2], a[0] * a[1]])
    return float(1.0 / (v @ np.linalg.solve(C, v)))
