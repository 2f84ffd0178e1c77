"""rigid/first_contact.py: the earliest time any two things of a rigid world could touch, a lower
bound from bounding spheres, then collision spheres, speeds, spins and gravity (sim/warm_up.py
relies on it: kernels a contact needs must have compiled by then). Checked against free fall and
uniform motion in closed form, the spheres' least gap against scipy's, and the step itself: no
contact is made before the bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid.bodies import add_box_body
from rigid.first_contact import earliest_contact_s

G = 9.81
DT = 1.0 / 240.0
HALF = np.array([0.05, 0.04, 0.03])  # m


def _reach(w, b):
    return float(w.body_reach()[b])


def _made_at(w) -> float:
    """s: the start of the step in which the world's first contact is made. A contact is made
    speculatively, for the closing the step itself can bring: up to one step before the pair touches."""
    steps = 0
    while w.n_contacts == 0:
        w.step(DT)
        steps += 1
    return (steps - 1) * DT


def _lowest(w, b) -> float:
    """m: the bottom of the body's lowest collision sphere, below its centre (unrotated)."""
    local, radius, body = w.sphere_data()
    return float((local[body == b][:, 1] - radius[body == b]).min())


def test_a_body_dropped_on_the_floor_falls_freely_until_its_lowest_sphere_meets_it(fresh):
    w = fresh
    w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    y0, v0 = 0.8, 0.5  # m, m/s (upwards: it rises first)
    b = add_box_body(w, HALF, 1000.0, x=(0.0, y0, 0.0), v=(0.0, v0, 0.0))
    margin = w.config.speculative_margin_m
    gap = y0 + _lowest(w, b) - margin
    assert gap > y0 - _reach(w, b) - margin  # nearer than the bounding sphere's
    expected = (math.sqrt(v0 * v0 + 2.0 * G * gap) - v0) / G  # the speed |v| towards it, the whole way
    t = earliest_contact_s(w, w.config.gravity, margin)
    assert t == pytest.approx(expected, rel=1e-12)
    made = _made_at(w)
    assert made >= t  # no contact before the bound (it rises first: the bound takes |v| as falling)
    assert made < 1.6 * t + 0.05  # and the bound is not far off for a compact body


def test_two_bodies_fall_together_and_close_at_their_relative_speed(fresh):
    w = fresh
    a = add_box_body(w, HALF, 1000.0, x=(-0.5, 1.0, 0.0), v=(1.0, 0.0, 0.0))
    b = add_box_body(w, HALF, 1000.0, x=(0.5, 1.0, 0.0), v=(-0.5, 2.0, 0.0))
    margin = w.config.speculative_margin_m
    rel = math.hypot(1.5, 2.0)
    assert earliest_contact_s(w, w.config.gravity, margin) == pytest.approx(
        (_least_sphere_gap(w, a, b) - margin) / rel, rel=1e-9)


def test_a_box_collider_and_an_overlap(fresh):
    w = fresh
    w.add_box_collider((0.0, 0.0, 0.0), (1.0, 0.1, 1.0))
    b = add_box_body(w, HALF, 1000.0, x=(0.3, 0.5, 0.2))
    margin = w.config.speculative_margin_m
    gap = 0.5 + _lowest(w, b) - 0.1 - margin  # above the box's top face
    assert earliest_contact_s(w, w.config.gravity, margin) == pytest.approx(math.sqrt(2.0 * gap / G), rel=1e-12)
    add_box_body(w, HALF, 1000.0, x=(0.305, 0.5, 0.2))  # its corner spheres overlap the first's
    assert earliest_contact_s(w, w.config.gravity, margin) == 0.0


def _least_sphere_gap(w, a, b) -> float:
    """m: the least gap between two bodies' collision spheres, from scipy's distance matrix."""
    from scipy.spatial.distance import cdist

    from rigid.quat import quat_to_matrix

    st = w.body_state()
    local, radius, body = w.sphere_data()
    x = [st.x[k] + local[body == k] @ quat_to_matrix(st.q[k]).T for k in (a, b)]
    r = [radius[body == k] for k in (a, b)]
    return float((cdist(x[0], x[1]) - r[0][:, None] - r[1][None]).min())


def test_bodies_whose_bounding_spheres_overlap_close_at_their_spheres_gap(fresh):
    """Side by side, 2 cm apart: the bounding spheres overlap, the collision spheres do not. Moving
    apart or together, they close at their relative speed over the spheres' least gap; and the step
    makes its first contact in the step where that time falls."""
    w = fresh
    w.config.gravity = (0.0, 0.0, 0.0)
    margin = w.config.speculative_margin_m
    a = add_box_body(w, HALF, 1000.0, x=(0.0, 1.0, 0.0), v=(0.3, 0.0, 0.0))
    b = add_box_body(w, HALF, 1000.0, x=(2 * HALF[0] + 0.02, 1.0, 0.0), v=(-0.2, 0.0, 0.0))
    assert 2 * _reach(w, a) > 2 * HALF[0] + 0.02  # the bounding spheres overlap: the first pass alone gives 0
    expected = (_least_sphere_gap(w, a, b) - margin) / 0.5
    t = earliest_contact_s(w, w.config.gravity, margin)
    assert t == pytest.approx(expected, rel=1e-9)
    assert t - DT < _made_at(w) <= t + 1e-9  # made in the step that closes the gap: the bound is exact here


def test_bodies_stacked_apart_fall_together_until_the_floor(fresh):
    """One box above another, their bounding spheres overlapping, both at rest: they fall together
    and cannot touch before the lower one reaches the floor (a pot stacked in the Pots scene)."""
    w = fresh
    w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    margin = w.config.speculative_margin_m
    a = add_box_body(w, HALF, 1000.0, x=(0.0, 0.5, 0.0))
    b = add_box_body(w, HALF, 1000.0, x=(0.0, 0.5 + 2 * HALF[1] + 0.01, 0.0))
    assert _least_sphere_gap(w, a, b) > margin
    assert earliest_contact_s(w, w.config.gravity, margin) == pytest.approx(
        math.sqrt(2.0 * (0.5 + _lowest(w, a) - margin) / G), rel=1e-12)  # the lower box's lowest sphere


def test_a_spinning_body_is_not_caught_out_by_its_spin(fresh):
    """A long box spun fast just above the floor: its ends sweep down faster than it falls. The bound
    counts the spin (and how far it can grow as it tumbles) and no contact comes before it."""
    w = fresh
    w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    margin = w.config.speculative_margin_m
    add_box_body(w, (0.2, 0.02, 0.03), 1000.0, x=(0.0, 0.1, 0.0), w=(1.0, 2.0, 25.0))
    t = earliest_contact_s(w, w.config.gravity, margin)
    assert 0.0 < t < math.sqrt(2.0 * 0.1 / G)  # sooner than its centre would fall to the floor
    assert _made_at(w) > t - DT  # never more than the speculative step before the bound


def test_a_world_without_bodies_or_motion_has_no_contact_to_come(fresh):
    w = fresh
    assert earliest_contact_s(w, w.config.gravity, 0.0) == math.inf
    add_box_body(w, HALF, 1000.0, x=(0.0, 1.0, 0.0))
    add_box_body(w, HALF, 1000.0, x=(1.0, 1.0, 0.0))
    assert earliest_contact_s(w, w.config.gravity, 0.0) == math.inf  # they fall side by side


def test_a_body_falling_onto_a_sleeping_one_closes_under_gravity(fresh):
    """A sleeping body does not fall (rigid/free_flight.py relies on the bound): the pair is not
    falling together, and the bound counts the upper body's fall."""
    w = fresh
    w.config.gravity = (0.0, 0.0, 0.0)
    low = add_box_body(w, HALF, 800.0, x=(0.0, 1.0, 0.0))
    while not w.body_state().asleep[low]:
        w.step(DT)
    w.config.gravity = (0.0, -G, 0.0)
    high = add_box_body(w, HALF, 800.0, x=(0.0, 1.3, 0.0))
    assert w.body_state().asleep[low]
    bound = earliest_contact_s(w, w.config.gravity, w.config.speculative_margin_m)
    gap = 0.3 + _lowest(w, high) - (-_lowest(w, low)) - w.config.speculative_margin_m
    assert bound == pytest.approx(math.sqrt(2.0 * gap / G), rel=1e-9)  # the spheres' gap, closed in free fall
    assert _made_at(w) + DT >= bound
