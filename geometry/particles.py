"""Physical particles from tetrahedra (Sect. 5.1): one particle per tet, linked across shared faces.

A particle sits at its tet's centroid, carries the tet's volume, its mass from the material
density, the radius `r = (3V / 4 pi)^(1/3)` and its four rest vertices (kept for cutting and
surfaces). Links join particles whose tets share a face; a particle with fewer than 4 links is a
surface particle. This is the host-side (numpy) form; `sim.stores` mirrors it in Taichi fields.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.arrays import unique_rows
from geometry.tetmesh import TetMesh, face_adjacency, signed_volumes

KIND_PHYSICAL = 0  # a particle made from an input tet
KIND_SUBDIVIDED = 1  # a child made by adaptive subdivision (Sect. 5.2)


def tet_edge(volume):
    """Edge (m) of the regular tet of each volume (m^3): a float for a scalar, else an array."""
    e = np.cbrt(6.0 * np.sqrt(2.0) * np.asarray(volume, dtype=np.float64))
    return float(e) if e.ndim == 0 else e


@dataclass
class ParticleSet:
    """Struct of arrays for tet particles of one or more bodies, in the reference frame (m, kg)."""

    rest_verts: np.ndarray  # (N, 4, 3) m: tet vertices in the reference frame
    volume: np.ndarray  # (N,) m^3
    mass: np.ndarray  # (N,) kg
    centroid: np.ndarray  # (N, 3) m: rest centroid
    radius: np.ndarray  # (N,) m: (3V / 4 pi)^(1/3)
    material: np.ndarray  # (N,) int32: material id
    body: np.ndarray  # (N,) int32: body id
    links: np.ndarray  # (N, 4) int64: particle across face k, or -1
    kind: np.ndarray  # (N,) int8: KIND_PHYSICAL or KIND_SUBDIVIDED
    parent: np.ndarray  # (N,) int64: parent particle of a subdivided child, or -1
    alive: np.ndarray  # (N,) bool: False for a particle replaced by its children
    extra_links: np.ndarray = field(default=None)  # (E, 2) int64: links not across a shared face (Fig. 5)

    def __post_init__(self) -> None:
        if self.extra_links is None:
            self.extra_links = np.zeros((0, 2), dtype=np.int64)

    def __len__(self) -> int:
        return len(self.volume)

    @property
    def link_count(self) -> np.ndarray:
        """(N,) int: face links plus extra links of each particle."""
        n = (self.links >= 0).sum(1)
        if len(self.extra_links):
            n = n + np.bincount(self.extra_links.ravel(), minlength=len(self))
        return n

    @property
    def surface(self) -> np.ndarray:
        """(N,) bool: alive particles with a tet face that has no face neighbour (fewer than 4 links)."""
        return self.alive & (self.links < 0).any(1)

    def link_pairs(self) -> np.ndarray:
        """(L, 2) int64: every link once (i < j), face links and extra links together."""
        i, k = np.nonzero(self.links >= 0)
        j = self.links[i, k]
        pairs = np.stack([i, j], 1)
        if len(self.extra_links):
            pairs = np.concatenate([pairs, self.extra_links])
        pairs = np.sort(pairs, axis=1)
        return unique_rows(pairs)


def build_particles(
    mesh: TetMesh, densities: np.ndarray | float, body: int = 0, material_ids: np.ndarray | None = None
) -> ParticleSet:
    """One physical particle per tet of `mesh`.

    densities: kg/m^3, a scalar or one value per region of `mesh.tet_region`.
    material_ids: material id per region (default: the region index itself).
    """
    pts = mesh.tet_points
    vol = signed_volumes(pts)
    region = mesh.tet_region
    dens = np.atleast_1d(np.asarray(densities, dtype=np.float64))
    rho = dens[region] if dens.size > 1 else np.full(len(vol), dens[0])
    mat = region if material_ids is None else np.asarray(material_ids, dtype=np.int32)[region]
    n = len(vol)
    return ParticleSet(
        rest_verts=pts.copy(),
        volume=vol,
        mass=rho * vol,
        centroid=pts.mean(axis=1),
        radius=np.cbrt(3.0 * vol / (4.0 * np.pi)),
        material=mat.astype(np.int32),
        body=np.full(n, body, dtype=np.int32),
        links=face_adjacency(mesh.tets, mesh.source),
        kind=np.full(n, KIND_PHYSICAL, dtype=np.int8),
        parent=np.full(n, -1, dtype=np.int64),
        alive=np.ones(n, dtype=bool),
    )


def concat_particles(parts: list[ParticleSet]) -> ParticleSet:
    """One ParticleSet from several, with link and parent indices shifted."""
    offsets = np.cumsum([0] + [len(p) for p in parts[:-1]])

    def shift(a: np.ndarray, off: int) -> np.ndarray:
        return np.where(a >= 0, a + off, a)

    return ParticleSet(
        rest_verts=np.concatenate([p.rest_verts for p in parts]),
        volume=np.concatenate([p.volume for p in parts]),
        mass=np.concatenate([p.mass for p in parts]),
        centroid=np.concatenate([p.centroid for p in parts]),
        radius=np.concatenate([p.radius for p in parts]),
        material=np.concatenate([p.material for p in parts]),
        body=np.concatenate([p.body for p in parts]),
        links=np.concatenate([shift(p.links, o) for p, o in zip(parts, offsets)]),
        kind=np.concatenate([p.kind for p in parts]),
        parent=np.concatenate([shift(p.parent, o) for p, o in zip(parts, offsets)]),
        alive=np.concatenate([p.alive for p in parts]),
        extra_links=np.concatenate([p.extra_links + o for p, o in zip(parts, offsets)]),
    )


def transform_particles(ps: ParticleSet, rot: np.ndarray, offset: np.ndarray) -> ParticleSet:
    """Rest data moved by x -> rot x + offset (a rigid motion keeps volumes and links)."""
    verts = ps.rest_verts @ rot.T + offset
    return ParticleSet(
        rest_verts=verts, volume=ps.volume.copy(), mass=ps.mass.copy(), centroid=verts.mean(1),
        radius=ps.radius.copy(), material=ps.material.copy(), body=ps.body.copy(), links=ps.links.copy(),
        kind=ps.kind.copy(), parent=ps.parent.copy(), alive=ps.alive.copy(), extra_links=ps.extra_links.copy(),
    )
