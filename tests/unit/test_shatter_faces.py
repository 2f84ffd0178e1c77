"""A shatter zone frees a particle where the energy it holds pays for the faces it opens
(geometry/freeing.py), against known answers on a regular tet linked across its four faces to four
regular tets (each the centre tet mirrored in one of its faces), all of face area A and surface 4A:

- a particle holding u / u_limit = r holds r 2A of crack energy (at G_c = 1);
- the centre tet alone must pay its four faces whole: freed from r = 2, not below (a lone particle
  needs twice the density of one inside a zone);
- with its four neighbours freed too it pays half of each: freed from r = 1 (the U_limit radius);
- an outer tet opens one face: A alone (r >= 1/2), A/2 beside a freed centre (r >= 1/4);
- the freed set is the largest that pays for itself: at r = 0.6 everywhere the centre cannot pay even
  beside freed neighbours, so it stays and the four outer tets, which then pay A each, are freed;
- an extra link (Fig. 5) in place of the face link costs the same face;
- what a blow frees never costs more crack energy than the shatter energy it releases (a subdivided
  glass pane; the crack area counted here from the links the freeing removed).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from geometry.freeing import freed_particles
from geometry.particles import build_particles, tet_edge
from geometry.tetmesh import TET_FACES, TetMesh, face_areas_normals, signed_volumes


def _star() -> tuple:
    """The regular tet (edge 2 sqrt2 cm) with a mirrored regular tet on each face: ParticleSet, face area."""
    s = 0.01
    centre = s * np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])
    if signed_volumes(centre[None])[0] < 0.0:
        centre = centre[[1, 0, 2, 3]]
    verts = [*centre]
    tets = [[0, 1, 2, 3]]
    for k in range(4):
        face = TET_FACES[k]
        verts.append(2.0 * centre[face].mean(0) - centre[k])  # vertex k mirrored in its face
        tets.append([*face, len(verts) - 1] if signed_volumes(np.array([[*centre[face], verts[-1]]]))[0] > 0
                    else [face[1], face[0], face[2], len(verts) - 1])
    ps = build_particles(TetMesh(np.array(verts), np.array(tets)), 2500.0)
    area, _ = face_areas_normals(ps.rest_verts)
    assert np.allclose(area, area[0, 0], rtol=1e-12) and np.allclose(ps.volume, ps.volume[0], rtol=1e-12)
    assert (ps.links[0] >= 0).all() and ((ps.links[1:] >= 0).sum(1) == 1).all()
    assert math.sqrt(3.0) * tet_edge(ps.volume[0]) ** 2 == pytest.approx(4.0 * area[0, 0], rel=1e-12)
    return ps, area[0, 0]


def _freed(ps, ratio, forced=()) -> list[int]:
    f = np.zeros(len(ps), dtype=bool)
    f[list(forced)] = True
    return np.flatnonzero(freed_particles(ps, np.arange(len(ps)), np.asarray(ratio, dtype=float), f)).tolist()


def test_a_lone_particle_pays_all_its_faces_one_in_a_zone_half():
    ps, _ = _star()
    assert _freed(ps, [1.99, 0, 0, 0, 0]) == []
    assert _freed(ps, [2.01, 0, 0, 0, 0]) == [0]
    assert _freed(ps, [1.01] * 5) == [0, 1, 2, 3, 4]
    assert _freed(ps, [0.99, 1.01, 1.01, 1.01, 1.01]) == [1, 2, 3, 4]  # the centre cannot pay half of four
    assert _freed(ps, [0.0, 0.51, 0.49, 0.0, 0.0]) == [1]  # an outer tet alone opens its one face
    assert _freed(ps, [0.0, 0.26, 0.24, 0.3, 0.3], forced=[0]) == [0, 1, 3, 4]  # beside a plug: half a face


def test_the_freed_set_is_the_largest_that_pays_for_itself():
    ps, _ = _star()
    assert _freed(ps, [0.6] * 5) == [1, 2, 3, 4]
    assert _freed(ps, [0.4] * 5) == []


def test_an_extra_link_opens_the_face_it_lies_across():
    ps, _ = _star()
    links = ps.links.copy()
    k_centre = int(np.flatnonzero(links[0] == 1)[0])
    links[0, k_centre] = -1
    links[1, links[1] == 0] = -1
    extra = replace(ps, links=links, extra_links=np.array([[0, 1]]))
    assert _freed(extra, [0.0, 0.51, 0.0, 0.0, 0.0]) == [1]
    assert _freed(extra, [0.0, 0.49, 0.0, 0.0, 0.0]) == []
    assert _freed(extra, [1.01] * 5) == [0, 1, 2, 3, 4]


def test_what_a_blow_frees_costs_no_more_than_the_energy_it_releases(taichi_runtime):
    """A pane first cut and subdivided across the contact point (children of a quarter to a twentieth
    of a tet lie around it), then shattered by the blow: the crack area the freeing opens (every link
    it removed, across the face the two particles share) times G_c stays below the shatter energy U,
    because each freed particle pays for its share from the energy it holds, which the poly6 spread
    integrates to U over the material. One radius for every size (the nearest particle's r_inner)
    would free the small children too."""
    from geometry.cutting import Crack, shatter_particles
    from geometry.fragments import apply_cracks
    from geometry.particles import KIND_SUBDIVIDED
    from tests.unit.test_shatter_energy import _glass_pane_analysis

    ps, glass, an = _glass_pane_analysis()
    P = an.cracks[0].point
    cut = Crack(point=P + np.array([0.0, 0.0031, 0.0]), normal=[0.0, 1.0, 0.0], r_outer=0.1)
    fine, _ = apply_cracks(ps, [cut], mode="subdivision", shatter=False)
    fine = replace(fine, body=np.where(fine.alive, 0, -1))
    near = np.linalg.norm(fine.centroid - P, axis=1) < an.r_inner
    assert (near & fine.alive & (fine.kind == KIND_SUBDIVIDED)).sum() > 10  # children inside r_inner
    out, freed = shatter_particles(fine, an.cracks, bodies=[0])
    before = {tuple(p) for p in fine.link_pairs()}
    opened = np.array(sorted(before - {tuple(p) for p in out.link_pairs()}))
    area, normal = face_areas_normals(fine.rest_verts)

    def facing(a, b):  # area of the face of a that faces b
        d = fine.centroid[b] - fine.centroid[a]
        return area[a, np.argmax(np.einsum("kfc,kc->kf", normal[a], d), axis=1)]

    crack_area = np.minimum(facing(opened[:, 0], opened[:, 1]), facing(opened[:, 1], opened[:, 0])).sum()
    assert freed.size > 0 and glass.toughness * crack_area < an.shatter_energy
    _, by_radius = shatter_particles(fine, replace(an.cracks[0], shatter=None), bodies=[0])
    assert set(freed) < set(by_radius)
