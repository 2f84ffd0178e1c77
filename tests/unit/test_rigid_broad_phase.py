"""The broad phase (rigid/broad_phase.py: each sphere listed in every grid cell its box covers) finds
exactly the sphere pairs that the narrow phase's test keeps, checked against every pair tested by
brute force in numpy: spheres of mixed sizes, far from the origin, on moving, resting and static
bodies, and with one sphere so large that the grid falls back to cells of two of its half-widths."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from geometry.particles import build_particles
from rigid.bodies import ball_tetmesh
from rigid.broad_phase import CELL_PER_MEAN_HALF_WIDTH
from rigid.mass import mass_properties, static_mass_properties
from rigid.quat import quat_from_axis_angle, quat_to_matrix
from rigid.world import RigidConfig, RigidWorld

DT = 1.0 / 240.0
ORIGIN = np.array([40.0, -3.0, 25.0])  # m: far from the origin, where a cell's corner rounds coarsely


def _cluster(w: RigidWorld, rng, bodies: int, giant: float | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """`bodies` bodies of 3-40 spheres (radii log-normal about 6 mm, a few 5x larger) crowded in a
    0.25 m box around ORIGIN, moving, spinning, a few static; `giant`: one more body with a single
    sphere of that radius. Returns each body's (local centres, radii)."""
    spheres = []
    for k in range(bodies + (giant is not None)):
        n = 1 if k == bodies else int(rng.integers(3, 40))
        local = rng.normal(0.0, 0.03, (n, 3))
        radius = np.clip(rng.lognormal(np.log(0.006), 0.5, n), 0.001, 0.05)
        radius[rng.random(n) < 0.05] *= 5.0
        if k == bodies:
            local, radius = np.zeros((1, 3)), np.array([giant])
        static = k % 9 == 4
        q = quat_from_axis_angle(rng.normal(size=3), rng.uniform(0.0, 3.0))
        w.add_body(static_mass_properties(np.zeros(3)) if static else _mass(), local, radius,
                   x=ORIGIN + rng.uniform(-0.12, 0.12, 3), q=q,
                   v=(0.0, 0.0, 0.0) if static else rng.normal(0.0, 1.5, 3),
                   w=(0.0, 0.0, 0.0) if static else rng.normal(0.0, 20.0, 3), static=static)
        spheres.append((local, radius))
    return spheres


@functools.cache
def _mass():
    """A 3 cm glass ball's mass properties, for every moving body (their spheres are set apart)."""
    ps = build_particles(ball_tetmesh(0.03, 2, 40), 2500.0)
    return mass_properties(ps.rest_verts, ps.mass)


def _brute_force_pairs(w: RigidWorld, spheres, state, dt: float) -> set[tuple[int, int]]:
    """Every (a, b), a < b on different bodies, that the narrow phase's test keeps (rigid/narrow_phase.py
    `scan_sphere`) at the step's start pose: the centres within both reaches and the margin, and the gap
    below the margin plus how far the pair can close (relative motion, bounded by both sweeps)."""
    margin = w.config.speculative_margin_m
    x, disp, sweep, arc, radius, body, active = [], [], [], [], [], [], []
    for b, (local, r) in enumerate(spheres):
        lx = local @ quat_to_matrix(state.q[b]).T
        moving = not w.body_is_static(b)
        v, om = (state.v[b], state.w[b]) if moving else (np.zeros(3), np.zeros(3))
        x.append(state.x[b] + lx)
        disp.append(dt * (v + np.cross(om, lx)))
        sweep.append(dt * np.linalg.norm(v) + np.linalg.norm(om) * dt * np.linalg.norm(lx, axis=1))
        arc.append(0.5 * (np.linalg.norm(om) * dt) ** 2 * np.linalg.norm(lx, axis=1))
        radius.append(r)
        body.append(np.full(len(r), b))
        active.append(np.full(len(r), moving))
    x, disp, sweep, arc, radius, body, active = map(np.concatenate, (x, disp, sweep, arc, radius, body, active))
    a, b = np.triu_indices(len(x), 1)
    dist = np.linalg.norm(x[a] - x[b], axis=1)
    far = (radius[a] + sweep[a] + margin + radius[b] + sweep[b]) * (1.0 + 1e-5)
    closing = np.linalg.norm(disp[a] - disp[b], axis=1) + arc[a] + arc[b]
    keep = ((body[a] != body[b]) & (active[a] | active[b]) & (dist <= far)
            & (dist - radius[a] - radius[b] < margin + np.minimum(closing, sweep[a] + sweep[b])))
    return set(zip(a[keep].tolist(), b[keep].tolist()))


def _step_pairs(w: RigidWorld) -> set[tuple[int, int]]:
    """The sphere pairs of the last step's contacts, each listed once (a pair whose boxes share
    several cells is met in one of them)."""
    ev = w.contact_events()
    sphere = ev.sphere_b >= 0
    pairs = list(zip(ev.sphere_a[sphere].tolist(), ev.sphere_b[sphere].tolist()))
    assert len(set(pairs)) == len(pairs)
    return set(pairs)


@pytest.fixture
def crowd(taichi_runtime):
    config = RigidConfig()
    config.gravity = (0.0, 0.0, 0.0)
    config.max_travel_per_step = 0.0  # steps not split: the contacts are those of the step's start
    w = RigidWorld(capacity_bodies=64, capacity_spheres=2048, capacity_colliders=1, config=config)
    yield w
    w.release()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_finds_every_pair_the_narrow_phase_keeps(crowd, seed):
    rng = np.random.default_rng(seed)
    spheres = _cluster(crowd, rng, bodies=24)
    for _ in range(3):  # the first step from the set-up pose, then two after the solver moved them
        state = crowd.body_state()
        crowd.step(DT)
        expected = _brute_force_pairs(crowd, spheres, state, DT)
        assert len(expected) > 50  # a crowd, not a handful
        assert _step_pairs(crowd) == expected
    s = crowd._s
    ns = sum(len(r) for _, r in spheres)
    # the cells were smaller than the largest sphere: that is what the multi-cell listing is for
    assert s.grid_cell[None] < 2.0 * s.max_half[None]
    assert s.grid_entries[None] > ns


def test_one_giant_sphere_falls_back_to_cells_that_fit(crowd):
    rng = np.random.default_rng(7)
    spheres = _cluster(crowd, rng, bodies=12, giant=2.0)
    state = crowd.body_state()
    crowd.step(DT)
    s = crowd._s
    # at a few mean half-widths the giant's box alone would cover more cells than the grid holds
    assert s.grid_entries[None] > 8 * s.cap_spheres
    assert s.grid_cell[None] == pytest.approx(2.01 * s.max_half[None])
    expected = _brute_force_pairs(crowd, spheres, state, DT)
    giant = set(crowd.body_spheres(len(spheres) - 1).tolist())
    assert any(a in giant or b in giant for a, b in expected)
    assert _step_pairs(crowd) == expected


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_resting_pair_within_the_margin_along_an_axis_is_found(crowd, axis):
    """Two resting spheres 1.5 mm apart along a grid axis (the margin is 2 mm), the pair moved across a
    whole cell in twelve places: wherever a cell's face falls between them, their boxes (each with half
    the margin) still share a cell."""
    r, gap = 0.006, 1.5e-3
    assert gap < crowd.config.speculative_margin_m
    cell = CELL_PER_MEAN_HALF_WIDTH * (r + 0.5 * crowd.config.speculative_margin_m)  # both spheres at rest
    offset = np.zeros(3)
    offset[axis] = 2 * r + gap
    for shift in np.linspace(0.0, cell, 12, endpoint=False):
        crowd.clear()
        start = ORIGIN.copy()
        start[axis] = np.floor(ORIGIN[axis] / cell) * cell - r - 0.5 * gap + shift  # the gap's middle on a face first
        for x in (start, start + offset):
            crowd.add_body(_mass(), np.zeros((1, 3)), [r], x=x)
        crowd.step(DT)
        assert crowd._s.grid_cell[None] == pytest.approx(cell)
        assert _step_pairs(crowd) == {(0, 1)}
