"""Boundary spheres on a crack's faces (geometry/boundary.py, `area_weights`): a subdivided child counts
for the part of its parent's surface it stands for, so the children on a crack's faces are grouped into
spheres about as large as the rest of the body's, and unsubdivided particles group as the paper's n."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.boundary import area_weights, build_boundary_particles
from geometry.cutting import Crack
from geometry.fragments import apply_cracks
from rigid.bodies import boundary_spheres, free_faces
from tests.unit.test_cut_meshes import kuhn_box, particles

GROUP = 4  # the paper's sampling size n


@pytest.fixture(scope="module")
def cut_box():
    """A 1 m box of 8^3 x 6 tets cut through its middle with subdivision: (particles, alive ids, labels)."""
    ps = particles(kuhn_box(8, 8, 8, jitter=0.1, seed=11))
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.05, 0.03, 1.0], r_outer=2.0)
    out, rep = apply_cracks(ps, [crack], mode="subdivision")
    assert rep.n_fragments == 2
    ids = np.flatnonzero(out.alive)
    return out, ids, rep.labels[ids]


def _spheres(ps, ids, labels, weighted: bool):
    """Spheres without the pull inside (each covers its members), weighted or the paper's fixed n."""
    free = free_faces(ps, ids, labels)
    w = area_weights(ps.radius, ps.parent, ids) if weighted else None
    return build_boundary_particles(ps.centroid[ids], ps.radius[ids], ps.mass[ids], labels.astype(np.int32),
                                    free.any(axis=1), GROUP, weight=w)


def test_area_weights_are_the_childs_share_of_its_parents_surface(cut_box):
    ps, ids, _ = cut_box
    w = area_weights(ps.radius, ps.parent, ids)
    child = ps.parent[ids] >= 0
    assert child.sum() > 100 and (~child).sum() > 100
    np.testing.assert_array_equal(w[~child], 1.0)
    parent_r = ps.radius[ps.parent[ids[child]]]
    np.testing.assert_allclose(w[child], (ps.radius[ids[child]] / parent_r) ** 2, rtol=1e-12)
    assert w[child].max() < 1.0 and w[child].min() > 0.0


def test_crack_faces_get_spheres_about_as_large_as_the_rest(cut_box):
    """The children on the crack's faces: half the spheres or fewer than with groups of n particles,
    and spheres at least 0.45x as large as those on the box's own faces (0.34x with groups of n).
    Every surface particle is in exactly one sphere (its mass counted once), inside its radius."""
    ps, ids, labels = cut_box
    surface = free_faces(ps, ids, labels).any(axis=1)
    crack_spheres = {}
    for weighted in (True, False):
        bp = _spheres(ps, ids, labels, weighted)
        sizes = np.diff(bp.member_start)
        sphere_of = np.repeat(np.arange(len(bp)), sizes)
        np.testing.assert_array_equal(np.sort(bp.members), np.flatnonzero(surface))
        np.testing.assert_allclose(bp.mass.sum(), ps.mass[ids[surface]].sum(), rtol=1e-12)
        x, r = ps.centroid[ids[bp.members]], ps.radius[ids[bp.members]]
        assert np.all(np.linalg.norm(x - bp.position[sphere_of], axis=1) + r <= bp.radius[sphere_of] * (1 + 1e-12))
        children = np.bincount(sphere_of, weights=ps.parent[ids[bp.members]] >= 0, minlength=len(bp))
        on_crack, elsewhere = children == sizes, children == 0
        crack_spheres[weighted] = int(on_crack.sum())
        ratio = np.median(bp.radius[on_crack]) / np.median(bp.radius[elsewhere])
        print(f"\n{'weighted' if weighted else 'groups of n'}: {len(bp)} spheres, {on_crack.sum()} on the crack's "
              f"faces, their median radius {ratio:.2f}x the box faces'")
        if weighted:
            assert ratio >= 0.45
    assert crack_spheres[True] <= 0.5 * crack_spheres[False]


def test_unsubdivided_particles_group_as_the_papers_n():
    """The box before its cut (physical particles only): weights of 1, the same spheres as without
    weights, groups of n or single corner particles (the build's cached groups stay valid)."""
    ps = particles(kuhn_box(6, 6, 6, jitter=0.1, seed=3))
    ids = np.arange(len(ps))
    labels = np.zeros(len(ps), np.int64)
    np.testing.assert_array_equal(area_weights(ps.radius, ps.parent, ids), 1.0)
    with_w, without = _spheres(ps, ids, labels, True), _spheres(ps, ids, labels, False)
    np.testing.assert_array_equal(with_w.members, without.members)
    np.testing.assert_array_equal(with_w.position, without.position)
    assert set(np.unique(np.diff(with_w.member_start))) <= {1, GROUP}
    full = boundary_spheres(ps, ids, labels, GROUP)  # with the pull inside, as a build makes them
    assert len(full) == len(with_w)
