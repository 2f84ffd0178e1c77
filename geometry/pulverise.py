"""The core of a shatter zone, crushed below the particle size (Sect. 4.2, U_limit; Fig. 9: "the
region within the inner radius is destroyed completely").

In subdivision mode the particles within a crack's `r_crush` of its point (sph/cracks.py step 8: a
perforation plug, and where the shatter energy frees grains of a quarter of the particle's volume)
are freed as grains one level finer than the physical particles, the level at which the adaptive
subdivision resolves a crack (Sect. 5.2; "adaptively subdivided particles ... regenerated in the
neighborhood of contact and crack areas", Sect. 1): each tet splits at its
centroid into four tets of a quarter of its volume (vertex k replaced by the centroid keeps the
orientation), with the parent's density, material, body and kernel, no links. Basic mode frees the
particles whole (geometry.cutting.shatter_particles). Mass is conserved (each child carries
rho V / 4 of its parent's density rho).
"""

from __future__ import annotations

import numpy as np

from geometry.cutting import GRAINS_PER_PARTICLE, Crack, shatter_radius2
from geometry.particles import KIND_PHYSICAL, ParticleSet
from geometry.subdivision import with_children


def centroid_split(verts: np.ndarray) -> np.ndarray:
    """(4T, 4, 3) m: the four children of each tet of `verts` (T, 4, 3), child k of tet t at row
    4 t + k: the tet with its vertex k moved to the centroid."""
    children = np.repeat(verts[:, None], 4, axis=1)  # (T, 4 children, 4 vertices, 3)
    k = np.arange(4)
    children[:, k, k] = verts.mean(axis=1)[:, None]
    return children.reshape(-1, 4, 3)


def pulverise(ps: ParticleSet, debris: np.ndarray, cracks: list[Crack]) -> tuple[ParticleSet, np.ndarray]:
    """Split the physical particles among `debris` (ids, already unlinked) that lie within a crack's
    r_crush (by their size, with the crack's ShatterField) into their four centroid children.
    Returns the new ParticleSet (children appended, parents dead) and the debris ids with each split
    parent replaced by its children (ascending)."""
    if len(debris) == 0 or not any(c.r_crush > 0.0 or c.shatter is not None for c in cracks):
        return ps, debris
    crushed = np.zeros(len(debris), dtype=bool)
    x = ps.centroid[debris]
    for c in cracks:
        crushed |= np.einsum("ij,ij->i", x - c.point, x - c.point) < shatter_radius2(c, ps.volume[debris], grains=True)
    parents = debris[crushed & (ps.kind[debris] == KIND_PHYSICAL)]
    if parents.size == 0:
        return ps, debris
    ch_verts = centroid_split(ps.rest_verts[parents])
    ch_parent = np.repeat(parents, GRAINS_PER_PARTICLE)
    ch_vol = np.repeat(ps.volume[parents] / GRAINS_PER_PARTICLE, GRAINS_PER_PARTICLE)
    n0 = len(ps)
    links = np.concatenate([ps.links, np.full((len(ch_verts), 4), -1, dtype=ps.links.dtype)])
    out = with_children(ps, parents, ch_parent, ch_verts, ch_vol, links, ps.extra_links)
    kept = debris[~np.isin(debris, parents)]
    return out, np.concatenate([kept, n0 + np.arange(len(ch_verts))])
