"""Cracks that reach another material (Sect. 6, Fig. 12): where a crack region first meets particles
of a different material, and the crack stopped there. The World restarts Algorithm 1 at those points
with the other material's constants and kernel (sim/fracture_stage.py, across_materials), and the
cracks it gives carry the stopped crack on (`carry_on`: with the fracture energy it had left).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from core.arrays import cross3
from core.errors import ConfigError
from geometry.cutting import Crack, in_region, signed_distance


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
    a2 = cross3(crack.normal, a1)
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
    r_inner = min(crack.r_inner, r)
    shatter = None if crack.shatter is None else replace(crack.shatter, cap=min(crack.shatter.cap, r))
    return replace(crack, r_outer=min(crack.r_outer, r), r_inner=r_inner, r_crush=min(crack.r_crush, r_inner),
                   shatter=shatter)


def carry_on(parent: Crack, crossing: MaterialCrossing, cracks: list[Crack], toughness_from: float,
             toughness_to: float, source: str) -> list[Crack]:
    """The cracks that the new material's analysis at a crossing gives (`cracks`, in its direction), as
    continuations of the parent crack stopped there: each runs at least as far as the fracture energy
    the parent had left allows, G_c B (r_outer - d) spent at the new material's G_c' (the parent
    would have run to r_outer); the shatter zone stays with the contact."""
    left = max(parent.r_outer - crossing.distance, 0.0) * toughness_from / toughness_to
    return [replace(c, r_outer=max(c.r_outer, left), r_inner=0.0, r_crush=0.0, shatter=None, source=source)
            for c in cracks]
