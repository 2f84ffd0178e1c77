"""Sect. 5.1: tetrahedralization, physical particles and links, checked against exact answers."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.boundary import build_boundary_particles
from geometry.build import build_object
from geometry.particles import build_particles
from geometry.shapes import Box, Figurine, Sphere, TaiChiDisk, lathe, rod
from geometry.tetmesh import TET_FACES, signed_volumes, validate_tets
from geometry.tetrahedralize import tetrahedralize

POT = dict(profile=[[0.05, 0.0], [0.09, 0.08], [0.06, 0.2]], thickness=0.008)


def rel_error(mesh, reference: float) -> float:
    return abs(mesh.volume - reference) / reference


def test_box_volume_is_exact_at_two_resolutions():
    box = Box((0.2, 0.1, 0.05))
    for h in (0.02, 0.01):
        mesh, _ = tetrahedralize(box, h)
        assert rel_error(mesh, 0.2 * 0.1 * 0.05) < 1e-12
        assert signed_volumes(mesh.tet_points).min() > 0


@pytest.mark.parametrize(
    "shape,coarse,fine",
    [(Sphere(0.1), 0.015, 0.01), (lathe(**POT), 0.02, 0.01)],
    ids=["sphere", "pot"],
)
def test_curved_volume_matches_trimesh_and_converges(shape, coarse, fine):
    reference = shape.reference_mesh().volume
    err_coarse = rel_error(tetrahedralize(shape, coarse)[0], reference)
    err_fine = rel_error(tetrahedralize(shape, fine)[0], reference)
    assert err_coarse < 0.01 and err_fine < 0.01
    assert err_fine < err_coarse


def test_pot_reference_mesh_agrees_with_pappus():
    pot = lathe(**POT)
    assert pot.reference_mesh().volume == pytest.approx(pot.exact_volume(), rel=1e-3)


@pytest.fixture(scope="module")
def pot_particles():
    mesh, _ = tetrahedralize(lathe(**POT), 0.01)
    return mesh, build_particles(mesh, 2400.0)


def test_interior_faces_shared_by_exactly_two_tets(pot_particles):
    mesh, _ = pot_particles
    faces = np.sort(mesh.tets[:, TET_FACES].reshape(-1, 3), axis=1)
    unique, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() == 2
    # the faces used once form a closed surface: each of their edges is used exactly twice
    boundary = unique[counts == 1]
    edges = np.sort(np.concatenate([boundary[:, [0, 1]], boundary[:, [1, 2]], boundary[:, [0, 2]]]), axis=1)
    _, edge_counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(edge_counts == 2)


def test_links_are_symmetric_and_follow_shared_faces(pot_particles):
    mesh, ps = pot_particles
    i, k = np.nonzero(ps.links >= 0)
    j = ps.links[i, k]
    assert np.all(j != i)
    # j links back to i
    assert np.all((ps.links[j] == i[:, None]).sum(1) == 1)
    # and the two tets really share the face: same three vertex ids
    face_i = np.sort(mesh.tets[i[:, None], TET_FACES[k]], axis=1)
    back = np.argmax(ps.links[j] == i[:, None], axis=1)
    face_j = np.sort(mesh.tets[j[:, None], TET_FACES[back]], axis=1)
    assert np.array_equal(face_i, face_j)


def test_surface_particles_are_tets_with_a_boundary_face(pot_particles):
    mesh, ps = pot_particles
    faces = np.sort(mesh.tets[:, TET_FACES].reshape(-1, 3), axis=1)
    _, inv, counts = np.unique(faces, axis=0, return_inverse=True, return_counts=True)
    owner_has_free_face = (counts[inv.ravel()] == 1).reshape(-1, 4).any(1)
    assert ps.surface.sum() == owner_has_free_face.sum()
    assert np.array_equal(ps.surface, owner_has_free_face)
    assert np.array_equal(ps.link_count < 4, ps.surface)


def test_particle_quantities(pot_particles):
    mesh, ps = pot_particles
    assert np.allclose(ps.centroid, mesh.tet_points.mean(1))
    assert np.allclose(ps.mass, 2400.0 * ps.volume)
    assert np.allclose(4 / 3 * np.pi * ps.radius**3, ps.volume)
    assert ps.mass.sum() == pytest.approx(2400.0 * mesh.volume, rel=1e-14)


@pytest.mark.parametrize("n", [1, 4, 8])
def test_boundary_particles_conserve_surface_mass(pot_particles, n):
    _, ps = pot_particles
    bp = build_boundary_particles(ps.centroid, ps.radius, ps.mass, ps.body, ps.surface, group_size=n)
    assert bp.mass.sum() == pytest.approx(ps.mass[ps.surface].sum(), rel=1e-13)
    # every surface particle belongs to exactly one sphere, and the sphere covers it
    assert np.array_equal(np.sort(bp.members), np.flatnonzero(ps.surface))
    sphere_of = np.repeat(np.arange(len(bp)), np.diff(bp.member_start))
    d = np.linalg.norm(ps.centroid[bp.members] - bp.position[sphere_of], axis=1) + ps.radius[bp.members]
    assert np.all(d <= bp.radius[sphere_of] * (1 + 1e-12))
    sizes = np.diff(bp.member_start)
    assert set(np.unique(sizes)) <= {1, n}
    if n > 1:  # most particles are grouped; only corner leftovers stand alone
        assert (sizes == n).sum() * n > 0.8 * ps.surface.sum()


def test_same_inputs_give_identical_particles_and_seed_moves_only_the_layered_sampler():
    a = build_object("sphere", resolution=0.02, seed=3)
    b = build_object("sphere", resolution=0.02, seed=4)  # the kept mesher has no randomness
    assert np.array_equal(a.particles.rest_verts, b.particles.rest_verts)
    assert np.array_equal(a.particles.links, b.particles.links)
    assert np.array_equal(a.boundary.position, b.boundary.position)
    box = Box((0.1, 0.1, 0.1))
    c, _ = tetrahedralize(box, 0.02, seed=3, layer_axis=[0, 0, 1])
    d, _ = tetrahedralize(box, 0.02, seed=3, layer_axis=[0, 0, 1])
    e, _ = tetrahedralize(box, 0.02, seed=4, layer_axis=[0, 0, 1])
    assert np.array_equal(c.verts, d.verts) and np.array_equal(c.tets, d.tets)
    assert not (c.verts.shape == e.verts.shape and np.array_equal(c.verts, e.verts))


@pytest.mark.parametrize(
    "shape,h",
    [
        (Box((0.4, 0.4, 0.008)), 0.008),
        (rod(0.01, 0.3), 0.005),
        (TaiChiDisk(0.1, 0.02), 0.01),
        (Figurine(0.2), 0.012),
    ],
    ids=["pane", "wire", "taichi", "pet"],
)
def test_every_shape_gives_a_valid_mesh(shape, h):
    mesh, report = tetrahedralize(shape, h)
    assert validate_tets(mesh) == []
    assert report["min_tet_volume_m3"] > 0
    assert report["tets"] > 100
    if shape.regions > 1:
        assert set(np.unique(mesh.tet_region)) == set(range(shape.regions))


def test_taichi_regions_split_the_disk_in_half():
    mesh, _ = tetrahedralize(TaiChiDisk(0.1, 0.02), 0.008)
    vol = mesh.volumes
    share = vol[mesh.tet_region == 1].sum() / vol.sum()
    assert share == pytest.approx(0.5, abs=0.03)


def test_layered_sampling_puts_vertices_in_layers():
    box = Box((0.1, 0.1, 0.1))
    mesh, _ = tetrahedralize(box, 0.02, layer_axis=[0, 0, 1], layer_spacing=0.01)
    inner = mesh.verts[np.all(np.abs(mesh.verts) < 0.05 - 1e-9, axis=1)]
    # interior vertices sit near planes z = k * 0.01 (jitter is 8% of h = 0.0016 m at most)
    offset = np.abs(inner[:, 2] / 0.01 - np.round(inner[:, 2] / 0.01)) * 0.01
    assert offset.max() <= 0.08 * 0.02 + 1e-12
    assert rel_error(mesh, 1e-3) < 1e-12


def test_resolution_budget_is_refused_with_the_allowed_range():
    from core.errors import ConfigError

    with pytest.raises(ConfigError, match="resolution"):
        tetrahedralize(Box((1.0, 1.0, 1.0)), 1e-4)


def test_boundary_spheres_of_many_bodies_at_once_equal_each_body_alone(pot_particles):
    """geometry/boundary.py groups every body in one pass (one tree, one grouping): each body gets the
    spheres it gets alone (pulled inside the surface, as a split makes them), a body of one surface
    particle included."""
    from rigid.bodies import boundary_spheres

    _, ps = pot_particles
    ids = np.flatnonzero(ps.alive)
    c = ps.centroid[ids]
    labels = (c[:, 0] > 0).astype(np.int64) + 2 * (c[:, 2] > 0) + 4 * (c[:, 1] > np.median(c[:, 1]))
    labels[np.argmin(c[:, 1])] = 8  # a piece of one particle
    together = boundary_spheres(ps, ids, labels, 4)
    for b in range(9):
        alone = boundary_spheres(ps, ids[labels == b], np.zeros(int((labels == b).sum()), np.int64), 4)
        mine = np.flatnonzero(together.body == b)
        assert len(mine) == len(alone) > 0
        np.testing.assert_array_equal(together.position[mine], alone.position)
        np.testing.assert_array_equal(together.radius[mine], alone.radius)
        np.testing.assert_array_equal(together.mass[mine], alone.mass)
        members = [ids[together.members[together.member_start[s]:together.member_start[s + 1]]] for s in mine]
        want = [ids[labels == b][alone.members[alone.member_start[s]:alone.member_start[s + 1]]]
                for s in range(len(alone))]
        assert all(np.array_equal(m, w) for m, w in zip(members, want))
