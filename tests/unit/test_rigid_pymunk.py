"""Planar cases against pymunk (Chipmunk2D), an independent 2D engine (DESIGN.md 5).

The 3D problem is planar: motion in x-y, rotation about z. A box with 8 corner spheres of radius r
touches a plane exactly like pymunk's rounded box (`Poly.create_box(size - 2r, radius=r)`): both
are the convex hull of the corner circles in the plane. Both engines run the same dt with the same
number of substeps; pymunk combines friction and elasticity as a product (ground 1.0), we as the
geometric mean / maximum, so the pair values agree.

Tolerances (stated in docs/notes_rigid.md): drop of a tilted box: COM within 1 cm and angle within
0.03 rad over 2 s, same rest pose within 5 mm; slide to a stop: within 2 mm of pymunk and of the
analytic v0^2 / (2 mu g); bounce: apex heights within 1 % of the drop height of pymunk and of e^2k h0.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from geometry.particles import build_particles
from rigid.bodies import add_box_body, ball_tetmesh
from rigid.mass import mass_properties
from rigid.quat import quat_from_axis_angle, quat_to_matrix
from rigid.world import RigidConfig

G = 9.81
DT = 1.0 / 240.0


def _pm_space(friction: float = 1.0, elasticity: float = 1.0) -> pymunk.Space:
    sp = pymunk.Space()
    sp.gravity = (0.0, -G)
    sp.iterations = 30
    sp.collision_slop = 1e-4
    ground = pymunk.Segment(sp.static_body, (-50.0, 0.0), (50.0, 0.0), 0.0)
    ground.friction = friction
    ground.elasticity = elasticity
    sp.add(ground)
    return sp


def _pm_box(sp, hx, hy, r, m, x, y, angle=0.0, vx=0.0, friction=0.5):
    body = pymunk.Body(m, m * ((2 * hx) ** 2 + (2 * hy) ** 2) / 12.0)
    body.position = (x, y)
    body.angle = angle
    body.velocity = (vx, 0.0)
    shape = pymunk.Poly.create_box(body, (2 * hx - 2 * r, 2 * hy - 2 * r), radius=r)
    shape.friction = friction
    shape.elasticity = 0.0
    sp.add(body, shape)
    return body


def _our_box(w, half, r, rho, x, y, angle=0.0, vx=0.0, friction=0.5):
    w.clear()
    w.config = RigidConfig(sleep_enabled=False)
    w.add_plane((0, 0, 0), (0, 1, 0), friction=friction)
    return add_box_body(
        w,
        half,
        rho,
        x=(x, y, 0.0),
        q=quat_from_axis_angle([0, 0, 1], angle),
        v=(vx, 0.0, 0.0),
        sphere_radius=r,
        friction=friction,
    )


def _step_both(w, sp, steps):
    m = w.config.substeps
    for _ in range(steps):
        w.step(DT)
        for _ in range(m):
            sp.step(DT / m)
        yield w.body_state()


def test_tilted_box_drop_matches_pymunk(world):
    half, r = (0.2, 0.1, 0.1), 0.02
    b = _our_box(world, half, r, 500.0, 0.0, 0.6, angle=0.5)
    sp = _pm_space()
    pb = _pm_box(sp, half[0], half[1], r, world.body_mass(b), 0.0, 0.6, angle=0.5)
    rows = []
    zmax = tilt = 0.0
    for st in _step_both(world, sp, int(2.0 / DT)):
        rot = quat_to_matrix(st.q[b])
        zmax, tilt = max(zmax, abs(st.x[b, 2])), max(tilt, abs(rot[2, 2] - 1.0))
        rows.append(
            (st.x[b, 0], st.x[b, 1], np.arctan2(rot[1, 0], rot[0, 0]), pb.position.x, pb.position.y, pb.angle)
        )
    rows = np.array(rows)
    dx, dy = np.abs(rows[:, 0] - rows[:, 3]).max(), np.abs(rows[:, 1] - rows[:, 4]).max()
    dang = np.abs(rows[:, 2] - rows[:, 5]).max()
    print(
        f"tilted drop vs pymunk: max |dx| {dx * 1e3:.2f} mm, |dy| {dy * 1e3:.2f} mm, "
        f"|dangle| {dang:.4f} rad; rest x {rows[-1, 0]:.4f} / {rows[-1, 3]:.4f} m; "
        f"out of plane {zmax * 1e3:.2f} mm, 1 - cos {tilt:.1e}"
    )
    # stays planar up to the symmetry breaking of the sequential (front before back) contact order
    assert zmax < 5e-3 and tilt < 1e-3
    assert dx < 0.01 and dy < 0.01 and dang < 0.03
    assert abs(rows[-1, 0] - rows[-1, 3]) < 5e-3
    assert (
        rows[-1, 1] == pytest.approx(half[1], abs=1e-4) and abs(rows[-1, 2]) < 1e-3
    )  # flat on its long side


def test_sliding_box_stops_like_pymunk_and_coulomb(world):
    v0, mu = 2.0, 0.5
    b = _our_box(world, (0.1, 0.1, 0.1), 0.02, 1000.0, 0.0, 0.1, vx=v0, friction=mu)
    sp = _pm_space(friction=1.0)
    pb = _pm_box(sp, 0.1, 0.1, 0.02, world.body_mass(b), 0.0, 0.1, vx=v0, friction=mu)
    rows = np.array([(st.x[b, 0], st.v[b, 0], pb.position.x) for st in _step_both(world, sp, int(1.0 / DT))])
    exact = v0 * v0 / (2 * mu * G)
    print(f"slide: ours {rows[-1, 0]:.5f} m, pymunk {rows[-1, 2]:.5f} m, analytic {exact:.5f} m")
    assert np.abs(rows[:, 0] - rows[:, 2]).max() < 2e-3
    assert rows[-1, 0] == pytest.approx(exact, abs=2e-3)
    assert abs(rows[-1, 1]) < 1e-6  # stopped, and stays stopped (static friction)


def test_bounce_heights_match_pymunk(world):
    e, h0, radius = 0.5, 1.0, 0.1
    w = world
    w.clear()
    w.config = RigidConfig(sleep_enabled=False)
    w.add_plane((0, 0, 0), (0, 1, 0))
    ps = build_particles(ball_tetmesh(radius, 3, 96), 1000.0)
    mp = mass_properties(ps.rest_verts, ps.mass)
    b = w.add_body(mp, np.zeros((1, 3)), [radius], x=(0.0, h0 + radius, 0.0), restitution=e)
    sp = _pm_space(elasticity=1.0)
    pb = pymunk.Body(mp.mass, pymunk.moment_for_circle(mp.mass, 0, radius))
    pb.position = (0.0, h0 + radius)
    shape = pymunk.Circle(pb, radius)
    shape.elasticity = e
    sp.add(pb, shape)
    ours, theirs = [], []
    for st in _step_both(w, sp, int(1.8 / DT)):
        ours.append(st.x[b, 1] - radius)
        theirs.append(pb.position.y - radius)

    def apexes(y):
        y = np.array(y)
        k = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:]))
        return y[k + 1]

    a_ours, a_pm = apexes(ours)[:2], apexes(theirs)[:2]
    print(f"bounce apexes: ours {a_ours}, pymunk {a_pm}, analytic {[e**2 * h0, e**4 * h0]}")
    assert len(a_ours) == 2 and len(a_pm) == 2
    np.testing.assert_allclose(a_ours, a_pm, atol=0.01 * h0)
    np.testing.assert_allclose(a_ours, [e**2 * h0, e**4 * h0], atol=0.01 * h0)
