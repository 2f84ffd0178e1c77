"""Small and thin fragments under the rigid solver: single-tet and needle bodies over 1,000 steps, and
a pile of 500 fragments settling on the ground."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from geometry.particles import build_particles
from rigid.bodies import add_box_body, add_tet_body, box_tetmesh
from rigid.world import RigidWorld

DT = 1.0 / 240.0  # s: the rigid step of a 60 fps scene with 4 substeps
G = 9.81


def energies(w: RigidWorld, bodies: list[int]) -> tuple[float, np.ndarray]:
    """(kinetic + potential energy of all bodies (J), rotational energy of each of `bodies` (J))."""
    from rigid.quat import quat_to_matrix

    st = w.body_state()
    e = w.kinetic_energy(st)
    for b in np.flatnonzero(st.alive):
        e += w.body_mass(int(b)) * G * st.x[b, 1]
    rot = []
    for b in bodies:
        R = quat_to_matrix(st.q[b])
        rot.append(0.5 * st.w[b] @ (R @ w.body_inertia(b) @ R.T) @ st.w[b])
    return float(e), np.array(rot)


@pytest.mark.slow  # about 20-40 s: runs in CI's slow pass (.ci/run)
def test_single_tet_and_needle_fragments_over_1000_steps():
    """Three single-tet bodies (one boundary sphere each), a 20:1 needle and a 100:1 needle (inertia
    floored), thrown spinning at the ground and at each other. Every step: finite; total energy never
    above the start (+0.1% for the position correction lifting resting bodies); each body's rotational
    energy below the start's total, hence |w| <= sqrt(2 E0 / I_min)."""
    w = RigidWorld(capacity_bodies=16, capacity_spheres=512, capacity_contacts=4096)
    try:
        w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.3, friction=0.5)
        rng = np.random.default_rng(1)
        bodies = []
        tets = build_particles(box_tetmesh([0.01, 0.01, 0.01], (1, 1, 1), center=(0.0, 0.3, 0.0)), 2500.0)
        for k in range(3):
            bodies.append(add_tet_body(w, tets, particle_ids=[k], group_size=1, offset=(0.03 * k, 0.0, 0.0),
                                       v=rng.normal(size=3), w=rng.normal(size=3) * 60.0, restitution=0.3))
        for half, cells, y in (([0.005, 0.005, 0.1], 20, 0.2), ([0.001, 0.001, 0.1], 100, 0.35)):
            ps = build_particles(box_tetmesh(half, (1, 1, cells), center=(0.0, y, 0.0)), 2500.0)
            bodies.append(add_tet_body(w, ps, group_size=4, v=(0.5, -1.0, 0.2), w=(30.0, 5.0, -40.0), restitution=0.3))
        inertia_min = np.array([np.linalg.eigvalsh(w.body_inertia(b))[0] for b in bodies])
        e0, _ = energies(w, bodies)
        w_max = np.zeros(len(bodies))
        for _ in range(1000):
            w.step(DT)
            st = w.body_state()
            assert all(np.all(np.isfinite(getattr(st, k)[st.alive])) for k in ("x", "q", "v", "w"))
            e, rot = energies(w, bodies)
            assert e <= e0 * (1.0 + 1e-3) and np.all(rot <= e0)
            w_max = np.maximum(w_max, np.linalg.norm(st.w[bodies], axis=1))
        assert np.all(w_max <= np.sqrt(2.0 * e0 / inertia_min))
        assert np.all(st.x[bodies, 1] > 0.0)  # all above the ground
        print(f"\nlargest |w| (rad/s): {np.round(w_max, 1)}; bound sqrt(2 E0 / I_min): "
              f"{np.round(np.sqrt(2 * e0 / inertia_min), 0)}")
    finally:
        w.release()


PILE_SLEEP_S = 3.0  # s: the 500-fragment pile is asleep within this time (measured: 2.0 s)


@pytest.mark.slow
def test_pile_of_500_fragments_settles():
    """500 tet cubes of 2 cm (6 tets, 8 corner spheres) in a 10 x 10 x 5 lattice with random orientations
    and speeds (0.2 m/s), dropped on the ground: all asleep within PILE_SLEEP_S; no fragment leaves the
    footprint (the lattice's extent grown by its initial height: the 45-degree cone a fragment could
    slide down); interpenetration between fragments and with the ground below half a sphere radius."""
    w = RigidWorld(capacity_bodies=512, capacity_spheres=4096)
    try:
        w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.1, friction=0.6)
        rng = np.random.default_rng(0)
        for i in range(10):
            for j in range(10):
                for k in range(5):
                    x = (np.array([i, k, j]) - [4.5, 0.0, 4.5]) * 0.026 + [0.0, 0.02 + 0.005 * k, 0.0]
                    q = rng.normal(size=4)
                    add_box_body(w, [0.01, 0.01, 0.01], 2500.0, x=x, q=q / np.linalg.norm(q),
                                 v=rng.normal(size=3) * 0.2, restitution=0.1, friction=0.6)
        x0 = w.body_state().x
        margin = x0[:, 1].max()
        lo, hi = x0[:, [0, 2]].min(0) - margin, x0[:, [0, 2]].max(0) + margin
        steps = 0
        while steps < PILE_SLEEP_S / DT:
            w.step(DT)
            steps += 1
            if steps % 24 == 0 and w.body_state().asleep.all():
                break
        st = w.body_state()
        assert st.asleep.all(), f"{(~st.asleep).sum()} fragments awake after {steps * DT:.2f} s"
        assert np.all((st.x[:, [0, 2]] >= lo) & (st.x[:, [0, 2]] <= hi))
        _, rad, body = w.sphere_data()
        xw = w.sphere_world(st)
        pairs = cKDTree(xw).query_pairs(2.0 * rad.max(), output_type="ndarray")
        pairs = pairs[body[pairs[:, 0]] != body[pairs[:, 1]]]
        depth = rad[pairs[:, 0]] + rad[pairs[:, 1]] - np.linalg.norm(xw[pairs[:, 0]] - xw[pairs[:, 1]], axis=1)
        assert depth.max() < 0.5 * rad.min()
        assert (rad - xw[:, 1]).max() < 0.5 * rad.min()
        print(f"\npile asleep after {steps * DT:.2f} s; deepest overlap {depth.max() * 1e3:.3f} mm "
              f"(sphere radius {rad.min() * 1e3:.1f} mm); spread {np.abs(st.x[:, [0, 2]]).max():.3f} m")
    finally:
        w.release()
