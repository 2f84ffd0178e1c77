"""Mass properties from tets (rigid.mass): exact integrals against analytic answers."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import MeshError
from geometry.particles import build_particles
from rigid.bodies import ball_tetmesh, box_tetmesh
from rigid.mass import inertia_floor, mass_properties, tet_second_moments
from rigid.quat import quat_to_matrix

EPS = np.finfo(np.float64).eps


def test_unit_tet_covariance_is_canonical():
    """int x x^T dV over the unit tet (0, e1, e2, e3) with rho = 1 is (1/120)[[2,1,1],[1,2,1],[1,1,2]]."""
    v = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]], dtype=float)
    c = tet_second_moments(v, np.array([1.0 / 6.0]), np.zeros(3))[0]
    np.testing.assert_allclose(c, (np.ones((3, 3)) + np.eye(3)) / 120.0, rtol=1e-15, atol=1e-17)


def test_second_moments_are_the_outer_products_bit_for_bit():
    """The six-entry columns give each tet exactly m/20 (sum_k v_k v_k^T + s s^T) as outer products in
    that order, and so the same sums over tets (a body's inertia does not move with the layout)."""
    rng = np.random.default_rng(3)
    v = rng.uniform(-0.1, 0.1, size=(517, 4, 3))
    m = rng.uniform(1e-4, 2e-4, 517)
    origin = v.mean(axis=(0, 1))
    d = v - origin
    s = d.sum(axis=1)
    vv = d[:, 0, :, None] * d[:, 0, None, :]
    for k in range(1, 4):
        vv += d[:, k, :, None] * d[:, k, None, :]
    vv += s[:, :, None] * s[:, None, :]
    outer = (m / 20.0)[:, None, None] * vv
    got = tet_second_moments(v, m, origin)
    assert np.array_equal(got, outer)
    assert np.array_equal(got.sum(axis=0), outer.sum(axis=0))


@pytest.mark.parametrize("div", [(1, 1, 1), (2, 3, 1)])
def test_box_of_tets_matches_the_solid_box(div):
    h = np.array([0.3, 0.2, 0.05])
    rho = 2400.0
    ps = build_particles(box_tetmesh(h, div, center=(1.0, -2.0, 0.5)), rho)
    mp = mass_properties(ps.rest_verts, ps.mass)
    m = rho * 8 * h.prod()
    a, b, c = 2 * h
    exact = m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    assert mp.mass == pytest.approx(m, rel=8 * EPS)
    np.testing.assert_allclose(mp.com, [1.0, -2.0, 0.5], atol=1e-14)
    np.testing.assert_allclose(mp.inertia, exact, rtol=1e-12, atol=1e-12 * exact.max())
    assert not mp.floored


def test_regular_tet_inertia_is_m_a2_over_20():
    a = 0.07
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) * a / (2 * np.sqrt(2))
    v = v[[0, 2, 1, 3]] if np.linalg.det(v[1:] - v[0]) < 0 else v
    mp = mass_properties(v[None] + 5.0, np.array([0.3]))
    np.testing.assert_allclose(mp.inertia, 0.3 * a * a / 20 * np.eye(3), rtol=1e-10)
    np.testing.assert_allclose(mp.com, [5.0, 5.0, 5.0], rtol=1e-15)


def test_rotation_covariance_and_principal_axes():
    """Rotating the tets rotates the inertia: I' = R I R^T; principal axes diagonalise it."""
    ps = build_particles(box_tetmesh([0.3, 0.2, 0.1], (2, 2, 1)), 1000.0)
    rot = quat_to_matrix(np.array([0.9, 0.2, -0.3, 0.25]) / np.linalg.norm([0.9, 0.2, -0.3, 0.25]))
    mp0 = mass_properties(ps.rest_verts, ps.mass)
    mp1 = mass_properties(ps.rest_verts @ rot.T, ps.mass)
    np.testing.assert_allclose(mp1.inertia, rot @ mp0.inertia @ rot.T, rtol=1e-12, atol=1e-14)
    ax = mp1.principal_axes
    assert np.linalg.det(ax) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(ax.T @ mp1.inertia @ ax, np.diag(mp1.principal_moments), atol=1e-14)
    np.testing.assert_allclose(mp1.inv_inertia @ mp1.inertia, np.eye(3), atol=1e-10)


def test_ball_converges_to_two_fifths_m_r2():
    mp = mass_properties(
        *(lambda p: (p.rest_verts, p.mass))(build_particles(ball_tetmesh(0.1, 4, 300), 1000.0))
    )
    # the inscribed polytope: mass and inertia a little below the ball's, within 3 %
    assert mp.mass == pytest.approx(1000 * 4 / 3 * np.pi * 1e-3, rel=0.03)
    np.testing.assert_allclose(mp.principal_moments, 0.4 * mp.mass * 0.01, rtol=0.03)
    np.testing.assert_allclose(mp.com, 0.0, atol=1e-4)


def test_needle_inertia_is_floored_and_cube_is_not():
    needle = build_particles(box_tetmesh([0.5, 0.004, 0.004], (20, 1, 1)), 1000.0)
    mp = mass_properties(needle.rest_verts, needle.mass)
    floor = inertia_floor(mp.mass, mp.volume)
    assert mp.floored
    assert mp.principal_moments.min() == pytest.approx(floor, rel=1e-12)
    assert np.linalg.eigvalsh(mp.inertia_exact).min() < floor
    # the large moments are untouched
    assert mp.principal_moments.max() == pytest.approx(np.linalg.eigvalsh(mp.inertia_exact).max(), rel=1e-12)


def test_mass_is_the_exact_sum_of_tet_masses():
    ps = build_particles(box_tetmesh([0.1, 0.1, 0.1], (3, 3, 3)), 2321.7)
    mp = mass_properties(ps.rest_verts, ps.mass)
    import math

    assert mp.mass == math.fsum(ps.mass.tolist())


@pytest.mark.parametrize(
    "verts,masses",
    [
        (np.zeros((0, 4, 3)), np.zeros(0)),
        (np.ones((1, 4, 3)), np.array([-1.0])),
        (np.full((1, 4, 3), np.nan), np.array([1.0])),
    ],
)
def test_bad_input_raises_mesh_error(verts, masses):
    with pytest.raises(MeshError):
        mass_properties(verts, masses)
