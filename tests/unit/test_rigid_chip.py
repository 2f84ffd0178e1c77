"""A chip (a body of a few tets) rests on its corners (geometry/chip_corners.py):
boundary spheres that lie on a line let a body roll on that line for ever (a 2 mm chip of the pot
spun at 90 rad/s 10 s after the drop). A small cube of six tets, whose surface particles make three
spheres on a line, now rests on its tets' corners; slid along a floor with friction it stops, as a
block does (sliding distance v^2 / (2 mu g)), and sleeps."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.boundary import build_boundary_particles
from geometry.chip_corners import CHIP_CORNERS
from geometry.particles import build_particles
from rigid.bodies import add_tet_body, boundary_spheres, box_tetmesh
from rigid.quat import quat_to_matrix

G = 9.81
DT = 1.0 / 240.0
HALF = 0.002  # m: half the cube's edge
MU = 0.5


@pytest.fixture(scope="module")
def cube():
    return build_particles(box_tetmesh((HALF, HALF, HALF)), 2400.0)


def test_a_chip_stands_on_spheres_at_its_corners(taichi_runtime, cube):
    ids = np.arange(len(cube))
    grouped = build_boundary_particles(cube.centroid, cube.radius, cube.mass, np.zeros(len(cube), np.int64),
                                       np.ones(len(cube), bool))  # no tets given: the paper's groups
    # the case: the paper's groups lie within their radius of one line (the principal axis)
    d = grouped.position - grouped.position.mean(0)
    axis = np.linalg.svd(d)[2][0]
    assert np.linalg.norm(d - np.outer(d @ axis, axis), axis=1).max() < grouped.radius.mean()
    bp = boundary_spheres(cube, ids, np.zeros(len(cube), np.int64), 4)
    assert len(bp) == 8 == CHIP_CORNERS  # the cube's eight corners
    assert bp.mass.sum() == pytest.approx(cube.mass.sum(), rel=1e-12)
    # each sphere passes through its corner of the cube, from inside its tet
    corners = np.array([[x, y, z] for x in (-HALF, HALF) for y in (-HALF, HALF) for z in (-HALF, HALF)])
    gap = np.linalg.norm(bp.position[:, None] - corners[None], axis=2)
    assert np.allclose(gap.min(1), bp.radius, rtol=1e-9) and len(set(gap.argmin(1))) == 8
    assert np.all(np.abs(bp.position) < HALF)
    # the corners span the cube in three dimensions: it stands on them, not on a line
    assert np.linalg.svd(bp.position - bp.position.mean(0), compute_uv=False)[2] > 0.5 * HALF


def test_a_chip_slid_along_the_floor_stops_and_sleeps(fresh, cube):
    w = fresh
    w.add_plane((0, 0, 0), (0, 1, 0), restitution=0.0, friction=MU)
    v0 = 0.2  # m/s
    b = add_tet_body(w, cube, offset=(0.0, HALF * 1.2, 0.0), v=(v0, 0.0, 0.0), friction=MU)
    x0 = w.body_state().x[b].copy()
    for _ in range(int(2.0 / DT)):
        w.step(DT)
    st = w.body_state()
    assert st.asleep[b]
    # it lies on a face: its lowest corner above the floor by less than a corner sphere's radius
    corners = cube.rest_verts.reshape(-1, 3) - w.body_ref_com(b)
    lowest = float((corners @ quat_to_matrix(st.q[b]).T + st.x[b])[:, 1].min())
    assert 0.0 <= lowest <= w.sphere_data()[1].max()
    slid = float(st.x[b, 0] - x0[0])
    # a block: v^2 / (2 mu g) = 4.1 mm; the chip may tip once, never roll away
    assert 0.0 < slid < 3.0 * v0**2 / (2.0 * MU * G)
