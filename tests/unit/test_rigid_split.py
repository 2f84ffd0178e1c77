"""Splitting a body into fragments (rigid.bodies.split_body): exact mass, momentum and angular
momentum to round-off, unchanged world positions of every tet, rebuilt boundary spheres."""

from __future__ import annotations

import math

import numpy as np

from geometry.particles import build_particles
from rigid.bodies import add_tet_body, box_tetmesh, split_body
from rigid.quat import quat_from_axis_angle, quat_to_matrix
from rigid.world import RigidConfig, RigidWorld

DT = 1.0 / 240.0


def _momenta(w, ids):
    st = w.body_state()
    p = np.zeros(3)
    lang = np.zeros(3)
    for b in ids:
        m = w.body_mass(b)
        rot = quat_to_matrix(st.q[b])
        p += m * st.v[b]
        lang += np.cross(st.x[b], m * st.v[b]) + rot @ w.body_inertia(b) @ rot.T @ st.w[b]
    return p, lang


def _world_vertices(w, b, verts):
    st = w.body_state()
    return (verts - w.body_ref_com(b)) @ quat_to_matrix(st.q[b]).T + st.x[b]


def test_split_conserves_mass_momentum_and_pose(world):
    w = world
    w.clear()
    w.config = RigidConfig(gravity=(0.0, 0.0, 0.0), sleep_enabled=False)
    ps = build_particles(box_tetmesh([0.2, 0.1, 0.08], (4, 2, 2)), 2500.0)
    parent = add_tet_body(
        w,
        ps,
        group_size=4,
        offset=(1.0, 2.0, -0.5),
        q=quat_from_axis_angle([1, 2, 0.5], 0.7),
        v=(0.3, -1.0, 2.0),
        w=(4.0, -2.0, 1.5),
    )
    for _ in range(5):  # a non-trivial pose
        w.step(DT)
    m_parent = w.body_mass(parent)
    p0, l0 = _momenta(w, [parent])
    before = _world_vertices(w, parent, ps.rest_verts.reshape(-1, 3)).reshape(-1, 4, 3)
    # three fragments: the -x half, a single tet (a one-particle fragment), the rest
    ids = np.arange(len(ps))
    labels = np.where(ps.centroid[:, 0] < 0.0, 7, 3)
    labels[5] = 11
    kids = split_body(w, parent, ps, ids, labels, group_size=4)
    assert len(kids) == 3
    st = w.body_state()
    assert not st.alive[parent] and st.alive[kids].all()
    assert parent not in w.sphere_data()[2]
    # mass: each child is the exactly rounded sum of its tets; together within 2 ulp of the parent
    masses = [w.body_mass(b) for b in kids]
    for b, lab in zip(kids, (3, 7, 11), strict=True):
        assert w.body_mass(b) == math.fsum(ps.mass[labels == lab].tolist())
        assert np.all(ps.body[labels == lab] == b)
        assert len(w.body_spheres(b)) > 0
    assert abs(math.fsum(masses) - m_parent) <= 2 * np.spacing(m_parent)
    # momentum and angular momentum to round-off
    p1, l1 = _momenta(w, kids)
    print(
        f"split: |dP| {np.abs(p1 - p0).max():.1e} |dL| {np.abs(l1 - l0).max():.1e} "
        f"(|P| {np.linalg.norm(p0):.2f}, "
        f"|L| {np.linalg.norm(l0):.2f})"
    )
    assert np.abs(p1 - p0).max() <= 1e-13 * np.linalg.norm(p0)
    assert np.abs(l1 - l0).max() <= 1e-13 * np.linalg.norm(l0)
    # every tet stays where it was
    for b, lab in zip(kids, (3, 7, 11), strict=True):
        sel = labels == lab
        after = _world_vertices(w, b, ps.rest_verts[sel].reshape(-1, 3)).reshape(-1, 4, 3)
        np.testing.assert_allclose(after, before[sel], atol=1e-14)
    # the fragments then move apart without gaining energy and keep linear momentum exactly
    ke0 = w.kinetic_energy()
    for _ in range(60):
        w.step(DT)
        p, _l = _momenta(w, kids)
        assert np.abs(p - p0).max() <= 1e-12 * np.linalg.norm(p0)
        assert w.kinetic_energy() <= ke0 * (1 + 1e-6)  # the DLM rotation keeps E to O(h^2), no drift


def test_split_of_a_resting_body_wakes_and_drops_its_fragments(world):
    w = world
    w.clear()
    w.config = RigidConfig()
    w.add_plane((0, 0, 0), (0, 1, 0))
    ps = build_particles(box_tetmesh([0.1, 0.05, 0.05], (2, 1, 1), center=(0.0, 0.05, 0.0)), 1000.0)
    b = add_tet_body(w, ps, group_size=1)
    for _ in range(240):
        w.step(DT)
    assert w.body_state().asleep[b]
    kids = split_body(w, b, ps, np.arange(len(ps)), (ps.centroid[:, 0] > 0).astype(int), group_size=1)
    st = w.body_state()
    assert not st.asleep[kids].any()
    for _ in range(120):
        w.step(DT)
    st = w.body_state()
    assert np.all(np.isfinite(st.x[kids])) and np.all(np.abs(st.v[kids]) < 0.5)


def test_split_of_a_static_pane_frees_only_the_unheld_shard(world):
    w = world
    w.clear()
    w.config = RigidConfig()
    ps = build_particles(box_tetmesh([0.2, 0.2, 0.01], (4, 4, 1), center=(0.0, 1.0, 0.0)), 2500.0)
    pane = add_tet_body(w, ps, group_size=4, static=True)
    labels = (ps.centroid[:, 0] > 0.1).astype(int)  # label 1: a strip at +x, no longer held
    kids = split_body(w, pane, ps, np.arange(len(ps)), labels, group_size=4, static_labels=[True, False])
    assert w.body_is_static(kids[0]) and not w.body_is_static(kids[1])
    x0 = w.body_state().x[kids].copy()
    for _ in range(24):
        w.step(DT)
    x1 = w.body_state().x[kids]
    np.testing.assert_array_equal(x1[0], x0[0])  # the held part stays
    assert x1[1, 1] < x0[1, 1] - 0.005  # the freed shard falls


def test_boundary_grouping_kernel_equals_the_python_rule():
    """geometry/boundary_groups.py: the serial kernel groups exactly as the Python loop it replaced,
    on random candidate lists with taken, free and self candidates, for several group sizes, with
    unsubdivided particles only (groups of n) and with subdivided children among them (weights < 1:
    larger groups, and leftover children joining a neighbour's group)."""
    from geometry.boundary_groups import greedy_groups, greedy_groups_reference

    rng = np.random.default_rng(7)
    for n, k, size in ((1, 1, 4), (7, 3, 4), (200, 12, 4), (150, 9, 3), (90, 6, 1), (60, 15, 6)):
        order = rng.permutation(n)
        near = np.concatenate([np.arange(n)[:, None], rng.integers(0, n, (n, k - 1))], axis=1)
        for row in near:  # a k-NN list has distinct entries
            _, first = np.unique(row, return_index=True)
            dup = np.setdiff1d(np.arange(k), first)
            row[dup] = row[0]
        ok = rng.random((n, k)) < 0.8
        got, next_got = greedy_groups(order, near, ok, size, 5)
        want, next_want = greedy_groups_reference(order, near, ok, size, 5)
        assert next_got == next_want
        assert np.array_equal(got, want)
        assert (got >= 5).all() and np.bincount(got - 5).max() <= size
        weight = np.where(rng.random(n) < 0.6, rng.uniform(0.01, 0.5, n), 1.0)
        got, next_got = greedy_groups(order, near, ok, size, 5, weight)
        want, next_want = greedy_groups_reference(order, near, ok, size, 5, weight)
        assert next_got == next_want
        assert np.array_equal(got, want)
        assert np.array_equal(np.unique(got), np.arange(5, next_got))  # every id has members
        members = np.bincount(got - 5)
        children = np.bincount(got - 5, weights=weight < 1.0)
        # unsubdivided particles alone: the paper's groups of n, or one on its own
        assert np.all(np.isin(members[children == 0], (1, size)))
        # fewer than n together: only a leftover child joining another child
        assert np.all(children[(members > 1) & (members < size)] >= 2)


def test_a_bodys_spheres_keep_consecutive_ids(taichi_runtime):
    """The narrow phase skips a sphere's own body by its id range (rigid/narrow_phase.py), which holds
    only while every body's spheres have consecutive ids: through splits, removals and a ball shot in."""
    from scenes.loader import load_scene
    from sim.world import World
    from viewer.actions import shoot_ball

    w = World(load_scene("glass_r3"))
    try:
        for _ in range(6):
            w.step_frame()
        shoot_ball(w, (0.0, 0.3, 0.3), (0.0, -1.0, -1.0), 5.0)
        w.step_frame()
        assert w.events
        s = w.rigid._s
        body = s.bp_body.to_numpy()[: w.rigid.n_spheres]
        end = s.body_sphere_end.to_numpy()
        for b in np.unique(body):
            ids = np.flatnonzero(body == b)
            assert ids[-1] - ids[0] + 1 == len(ids), f"body {b}: spheres {ids[0]}..{ids[-1]} not consecutive"
            assert end[b] == ids[-1] + 1
    finally:
        w.release()


def test_wake_near_finds_every_body_with_a_sphere_in_the_box(fresh):
    """`wake_near` places only the spheres of bodies whose bounding sphere reaches the removed body's
    padded box: the bodies it finds are those a placement of every sphere finds, for rotated boxes
    scattered round the one removed (some inside the box, some outside)."""
    from rigid.bodies import add_box_body

    rng = np.random.default_rng(3)
    ids = []
    for k in range(12):
        axis = rng.normal(size=3)
        q = quat_from_axis_angle(axis / np.linalg.norm(axis), float(rng.uniform(0.0, math.pi)))
        x = (0.0, 0.5, 0.0) if k == 0 else rng.uniform([-0.6, 0.1, -0.6], [0.6, 0.9, 0.6])
        ids.append(add_box_body(fresh, (0.08, 0.03, 0.05), 1000.0, x=x, q=q))
    pad = 0.15
    for struck in ids[:4]:
        xw = fresh.sphere_world()
        body = fresh._sph_body
        mine = body == struck
        r = fresh._sph_radius
        lo, hi = (xw[mine] - r[mine, None]).min(0) - pad, (xw[mine] + r[mine, None]).max(0) + pad
        inside = np.all((xw >= lo) & (xw <= hi), axis=1) & ~mine
        want = np.unique(body[inside])
        assert 0 < len(want) < len(ids) - 1  # the case has bodies on both sides of the box
        np.testing.assert_array_equal(fresh.wake_near([struck], pad=pad), want)


def test_a_split_in_one_change_leaves_the_world_as_remove_then_add(world):
    """split_body replaces the parent by its pieces in one change (RigidWorld.replace_bodies: the
    spheres after the parent's uploaded and the warm-start contacts renumbered once); the world it
    leaves is the one `remove_bodies` then `add_bodies` leave: the same spheres, the same warm-start
    contacts, and 30 steps later the same poses and velocities, bit for bit. The parent sits between
    two bodies resting against it on a floor, so spheres and contacts on both sides are renumbered."""

    def run(one_change: bool):
        w = world
        w.clear()
        w.config = RigidConfig()
        w.add_plane((0, 0, 0), (0, 1, 0))
        boxes = []
        for dx in (-0.1, 0.0, 0.1):  # three boxes side by side, touching
            ps = build_particles(box_tetmesh([0.1, 0.05, 0.05], (2, 1, 1), center=(dx, 0.025, 0.0)), 1000.0)
            boxes.append((add_tet_body(w, ps, group_size=1, v=(-dx, 0.0, 0.0)), ps))
        for _ in range(30):
            w.step(DT)
        parent, ps = boxes[1]
        if not one_change:  # the two changes split_body made before: remove_bodies, then add_bodies
            w.replace_bodies = lambda ids, specs: (RigidWorld.replace_bodies(w, ids, []),
                                                   RigidWorld.replace_bodies(w, (), specs))[1]
        kids = split_body(w, parent, ps, np.arange(len(ps)), (ps.centroid[:, 0] > 0.0).astype(int), group_size=1)
        w.__dict__.pop("replace_bodies", None)
        after = [*w.sphere_data(), *w._download_prev()]
        for _ in range(30):
            w.step(DT)
        st = w.body_state()
        return kids, after, [st.x, st.q, st.v, st.w]

    kids, changed, state = run(True)
    kids_2, changed_2, state_2 = run(False)
    assert kids == kids_2 and len(changed[3]) > 0  # warm-start contacts were kept across the split
    for a, b in zip(changed + state, changed_2 + state_2, strict=True):
        np.testing.assert_array_equal(a, b)
