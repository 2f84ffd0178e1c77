"""Which particles a shatter zone frees (Sect. 4.2, U_limit): a particle pays for the crack faces it opens.

The paper frees every particle within r_inner, where the shatter energy density reaches U_limit. Its
reading here (docs/notes_cracks.md section 4) is u_limit = G_c A / (2 V): the density that pays for half
of a regular tet's surface, which is what a particle inside a shatter zone opens (each of its faces is a
crack shared with a freed neighbour). At the zone's edge and on a body's surface that is not so: a face
on the surface or on an earlier crack opens nothing, and a face to a neighbour that stays is a whole
crack that the freed particle pays alone. A particle is therefore freed when the energy it holds, u V,
pays

    G_c sum_f A_f (1/2 where the particle across f is freed too, else 1)

over the faces f it is still linked across (an extra link, Fig. 5, across the face of the smaller
particle that faces the other). The freed set is the largest that pays for itself: start from every
particle the energy reaches, drop those that cannot pay, and repeat; each drop makes its neighbours pay
more, so the rounds shrink the set to the greatest self-consistent one. Inside a zone of linked
particles this is the U_limit radius itself; a lone particle at a corner must hold twice the density.
"""

from __future__ import annotations

import numpy as np

from geometry.particles import ParticleSet, tet_edge
from geometry.tetmesh import face_areas_normals

SHARED = 0.5  # -: share of a crack's energy each of two freed neighbours pays


def _extra_link_areas(ps: ParticleSet, pairs: np.ndarray) -> np.ndarray:
    """(E,) m^2: the area an extra link (i, j) opens, the smaller of the two faces (one of each
    particle) that face the other particle's centroid most directly."""
    def facing(a, b):
        area, normal = face_areas_normals(ps.rest_verts[a])
        d = ps.centroid[b] - ps.centroid[a]
        return area[np.arange(len(a)), np.argmax(np.einsum("kfc,kc->kf", normal, d), axis=1)]

    return np.minimum(facing(pairs[:, 0], pairs[:, 1]), facing(pairs[:, 1], pairs[:, 0]))


def freed_particles(ps: ParticleSet, idx: np.ndarray, ratio: np.ndarray, forced: np.ndarray) -> np.ndarray:
    """(K,) bool over the candidate particles `idx`: those the shatter energy frees, by the rule above.

    ratio: (K,) -, u / u_limit of each candidate (module doc); forced: (K,) bool, freed whatever the
    energy (a striker's plug, a radius-only crack)."""
    n = len(idx)
    if n == 0:
        return np.zeros(0, dtype=bool)
    budget = ratio * 0.5 * np.sqrt(3.0) * tet_edge(ps.volume[idx]) ** 2  # m^2 of crack it pays at G_c
    area, _ = face_areas_normals(ps.rest_verts[idx])
    nb = ps.links[idx]  # (K, 4)
    linked = nb >= 0
    ex = ps.extra_links
    candidate = np.zeros(len(ps), dtype=bool)
    candidate[idx] = True
    if len(ex):
        ex = ex[candidate[ex[:, 0]] | candidate[ex[:, 1]]]
    ex_area = _extra_link_areas(ps, ex) if len(ex) else np.zeros(0)
    local = np.full(len(ps), -1, dtype=np.int64)
    local[idx] = np.arange(n)
    freed = forced | (ratio > 0.0)
    while True:
        in_set = np.zeros(len(ps), dtype=bool)
        in_set[idx[freed]] = True
        share = np.where(in_set[np.maximum(nb, 0)], SHARED, 1.0)
        cost = (area * share * linked).sum(axis=1)
        for a, b in ((0, 1), (1, 0)):
            ends = local[ex[:, a]]
            mine = ends >= 0
            w = ex_area[mine] * np.where(in_set[ex[mine, b]], SHARED, 1.0)
            cost += np.bincount(ends[mine], weights=w, minlength=n)
        keep = forced | (freed & (budget >= cost))
        if np.array_equal(keep, freed):
            return freed
        freed = keep
