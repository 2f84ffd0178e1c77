"""The struck surface (sim/struck_surface.py) is found from the faces near the contact only: the same
point, normal and radius of curvature, bit for bit, as from every free face of the body, for contacts
on a hollow pot (outside, inside the hollow, on the rim, far off the body) and a pane."""

from __future__ import annotations

import numpy as np
import pytest

from bench.study_pattern import pane as make_pane
from core.arrays import unique_rows
from geometry.build import build_object
from geometry.particles import tet_edge
from sim.struck_surface import (
    _facing_faces,
    _frame_of,
    _nearest_patch,
    _radius_of,
    _surface_particles,
    surface_frame,
    surface_radius_at,
)


@pytest.fixture(scope="module", params=["pot", "pane"])
def body(request):
    ps = build_object("pot").particles if request.param == "pot" else make_pane().particles
    return ps, float(tet_edge(float(np.median(ps.volume))))


def contacts(ps, n: int = 24):
    """Contact points and striker directions: at surface particles, pulled off the body, in the hollow,
    far away, with normals of every direction (some facing no face at all)."""
    rng = np.random.default_rng(7)
    c = ps.centroid
    lo, hi = c.min(0), c.max(0)
    rows = _surface_particles(ps, 0)
    points = [c[rng.choice(rows)] + rng.normal(0.0, 0.01, 3) for _ in range(n)]
    points += [0.5 * (lo + hi), lo - 0.3 * (hi - lo), hi + 2.0 * (hi - lo)]  # the middle (a pot's hollow), far off
    normals = rng.normal(size=(len(points), 3))
    return points, normals / np.linalg.norm(normals, axis=1, keepdims=True)


def test_the_patch_near_the_contact_gives_the_whole_body_answer(body):
    ps, edge = body
    every = _surface_particles(ps, 0)
    striker = np.array([0.01, 0.02, -0.03])
    for point, normal in zip(*contacts(ps)):
        whole = _facing_faces(ps, every, point, normal)
        for radius in (0.5 * edge, edge, 3.0 * edge):
            want = _frame_of(whole, point, normal, radius, striker)
            got = surface_frame(ps, 0, point, normal, radius, striker=striker)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
            wide = 2.0 * radius
            assert surface_radius_at(ps, 0, point, normal, wide) == _radius_of(whole, point, normal, wide)
        patch = _nearest_patch(ps, 0, point, normal, edge)
        assert (patch is None) == (whole is None)
        if patch is not None:  # the patch is a subset of the body's facing faces
            assert len(patch[0]) <= len(whole[0])


def test_a_body_without_free_faces_keeps_the_contact(body):
    ps, edge = body
    point, normal = np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    got = surface_frame(ps, 5, point, normal, edge)  # body 5 has no particles
    assert got[0] is point and got[1] is normal
    assert surface_radius_at(ps, 5, point, normal, edge) == np.inf


def test_a_patchs_corners_by_unique_rows_are_numpys(body):
    """The struck patch's distinct corners (`_radius_of`, by core.arrays.unique_rows' lexsort) are
    `np.unique(corners, axis=0)`'s rows in its order, on the corners of every facing face of the body
    (shared corners repeat)."""
    ps, _ = body
    point = ps.centroid.mean(0)
    tri, _, _ = _facing_faces(ps, _surface_particles(ps, 0), point, np.array([0.0, 1.0, 0.0]))
    corners = tri.reshape(-1, 3) - point
    want = np.unique(corners, axis=0)
    got = unique_rows(corners)
    assert got.shape == want.shape and np.array_equal(got, want)
    assert len(want) < len(corners)  # the corners repeat
