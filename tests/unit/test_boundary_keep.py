"""Groups kept through a split (geometry/boundary.py, `keep`; sim/bodies.py): a fragment keeps every
group of its parent's boundary spheres whose members are all still surface particles of that fragment
with the free faces they had, with the parent's very sphere; only the other surface particles (the
crack's faces and the groups the crack broke) are grouped anew."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from geometry.boundary import face_bits
from geometry.cutting import Crack
from geometry.fragments import apply_cracks
from rigid.bodies import boundary_spheres, free_faces
from sim.bodies import kept_groups, sphere_groups
from tests.unit.test_cut_meshes import kuhn_box, particles

GROUP = 4  # the paper's sampling size n


@pytest.fixture(scope="module")
def split_box():
    """A 1 m box of 8^3 x 6 tets with its spheres, cut in two with subdivision: (box particles, its
    spheres, its groups by row, cut particles, alive ids, labels). Rows keep their index through the
    cut (children come after), as store ids do."""
    box = particles(kuhn_box(8, 8, 8, jitter=0.1, seed=5))
    rows = np.arange(len(box))
    whole = boundary_spheres(box, rows, np.zeros(len(box), np.int64), GROUP)
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.1, -0.05, 1.0], r_outer=2.0)
    cut, rep = apply_cracks(box, [crack], mode="subdivision")
    assert rep.n_fragments == 2
    ids = np.flatnonzero(cut.alive)
    return box, whole, sphere_groups(whole, rows, 0), cut, ids, rep.labels[ids]


def _expected_kept(box, whole, cut, ids, labels) -> set[int]:
    """The parent's groups that should stay, by the rule read plainly, one group at a time."""
    before = free_faces(box, np.arange(len(box)), np.zeros(len(box), np.int64))
    after = free_faces(cut, ids, labels)
    where = {int(r): k for k, r in enumerate(ids)}
    kept = set()
    for g in range(len(whole)):
        members = whole.members[whole.member_start[g]:whole.member_start[g + 1]]
        if not all(int(m) in where for m in members):
            continue
        pos = [where[int(m)] for m in members]
        same_faces = all((after[p] == before[m]).all() for p, m in zip(pos, members))
        if same_faces and after[pos].any(axis=1).all() and len({int(labels[p]) for p in pos}) == 1:
            kept.add(g)
    return kept


def _groups(bp, rows) -> list[tuple]:
    """Each sphere's members as a tuple of rows (`rows`: the row of each member position)."""
    return [tuple(rows[bp.members[bp.member_start[s]:bp.member_start[s + 1]]]) for s in range(len(bp))]


def _leading_kept(bp, ids, parent: set) -> int:
    """How many spheres at the head of each body's are groups of the parent (kept groups come first)."""
    groups, count = _groups(bp, ids), 0
    for b in np.unique(bp.body):
        s = int(np.searchsorted(bp.body, b))
        while s < len(bp) and bp.body[s] == b and groups[s] in parent:
            count, s = count + 1, s + 1
    return count


def test_a_fragment_keeps_the_groups_the_crack_left_whole_with_their_spheres(split_box):
    box, whole, groups, cut, ids, labels = split_box
    bp = boundary_spheres(cut, ids, labels, GROUP, keep=kept_groups(groups, ids))
    expected = _expected_kept(box, whole, cut, ids, labels)
    assert 0.5 * len(whole) < len(expected) < len(whole)  # a crack through the middle breaks some groups only
    parent = _groups(whole, np.arange(len(box)))
    sphere_of = {g: s for s, g in enumerate(_groups(bp, ids))}
    for g in expected:  # the same members in the same order: the parent's sphere, bit for bit
        s = sphere_of[parent[g]]
        assert bp.position[s].tolist() == whole.position[g].tolist() and bp.radius[s] == whole.radius[g]
        assert bp.mass[s] == whole.mass[g]
    assert _leading_kept(bp, ids, set(parent)) == len(expected)


def test_a_kept_sphere_taken_as_it_was_is_the_one_made_again(split_box):
    """A kept group's sphere is taken from its parent (only the new groups' spheres are made): the
    spheres are, bit for bit, those made again from the kept members, as without the parent's spheres."""
    _, _, groups, cut, ids, labels = split_box
    keep = kept_groups(groups, ids)
    taken = boundary_spheres(cut, ids, labels, GROUP, keep=keep)
    made = boundary_spheres(cut, ids, labels, GROUP, keep=replace(keep, position=None, radius=None, mass=None))
    for name in ("position", "radius", "mass", "body", "member_start", "members", "member_faces"):
        assert np.array_equal(getattr(taken, name), getattr(made, name)), name
    moved = replace(keep, position=keep.position + 1.0)  # taken, not made: a moved parent sphere shows
    assert not np.array_equal(boundary_spheres(cut, ids, labels, GROUP, keep=moved).position, taken.position)


def test_every_surface_particle_is_in_one_sphere_kept_or_new(split_box):
    """The kept groups and the new ones cover each fragment's surface once, with its mass counted once
    and each member's faces as they are now; without `keep` a whole regrouping covers the same surface."""
    _, _, groups, cut, ids, labels = split_box
    surface = free_faces(cut, ids, labels).any(axis=1)
    for keep in (kept_groups(groups, ids), None):
        bp = boundary_spheres(cut, ids, labels, GROUP, keep=keep)
        np.testing.assert_array_equal(np.sort(bp.members), np.flatnonzero(surface))
        sphere_of = np.repeat(np.arange(len(bp)), np.diff(bp.member_start))
        np.testing.assert_array_equal(bp.body[sphere_of], labels[bp.members])
        np.testing.assert_allclose(bp.mass.sum(), cut.mass[ids[surface]].sum(), rtol=1e-12)
        np.testing.assert_array_equal(bp.member_faces, face_bits(free_faces(cut, ids, labels))[bp.members])


def test_a_group_whose_member_changed_its_faces_is_grouped_anew(split_box):
    box, whole, _, cut, ids, labels = split_box
    expected = sorted(_expected_kept(box, whole, cut, ids, labels))
    altered = sphere_groups(whole, np.arange(len(box)), 0)
    altered.member_faces[altered.member_start[expected[len(expected) // 2]]] ^= 1  # one more face freed
    bp = boundary_spheres(cut, ids, labels, GROUP, keep=kept_groups(altered, ids))
    assert _leading_kept(bp, ids, set(_groups(whole, np.arange(len(box))))) == len(expected) - 1


def test_groups_by_store_id_map_back_to_the_same_positions(split_box):
    """sphere_groups then kept_groups: members as store ids and back; one no longer there is -1."""
    whole = split_box[1]
    store = np.arange(whole.members.max() + 1) * 3 + 7  # the ascending store id of each row
    by_store = sphere_groups(whole, store, 0)
    back = kept_groups(by_store, store)
    np.testing.assert_array_equal(back.members, whole.members)
    gone = np.delete(store, whole.members[0])
    back = kept_groups(by_store, gone)
    assert back.members[0] == -1 and (back.members[1:] >= 0).all()
    assert kept_groups(None, store) is None
