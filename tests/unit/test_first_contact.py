"""rigid/first_contact.py: the earliest time any two things of a rigid world could touch, a lower
bound from bounding spheres, speeds and gravity (sim/warm_up.py relies on it: kernels a contact
needs must have compiled by then). Checked against free fall and uniform motion in closed form, and
against the step itself: no contact is made before the bound."""

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


def test_a_body_dropped_on_the_floor_falls_freely_until_its_bounding_sphere_meets_it(fresh):
    w = fresh
    w.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    y0, v0 = 0.8, 0.5  # m, m/s (upwards: it rises first)
    b = add_box_body(w, HALF, 1000.0, x=(0.0, y0, 0.0), v=(0.0, v0, 0.0))
    margin = w.config.speculative_margin_m
    gap = y0 - _reach(w, b) - margin
    expected = (math.sqrt(v0 * v0 + 2.0 * G * gap) - v0) / G  # the speed |v| towards it, the whole way
    t = earliest_contact_s(w, w.config.gravity, margin)
    assert t == pytest.approx(expected, rel=1e-12)
    steps = 0
    while w.n_contacts == 0:
        w.step(DT)
        steps += 1
    assert (steps - 1) * DT >= t  # no contact before the bound (it came in the step that ended at steps * DT)
    assert steps * DT < 1.6 * t + 0.05  # and the bound is not far off for a compact body


def test_two_bodies_fall_together_and_close_at_their_relative_speed(fresh):
    w = fresh
    a = add_box_body(w, HALF, 1000.0, x=(-0.5, 1.0, 0.0), v=(1.0, 0.0, 0.0))
    b = add_box_body(w, HALF, 1000.0, x=(0.5, 1.0, 0.0), v=(-0.5, 2.0, 0.0))
    margin = w.config.speculative_margin_m
    rel = math.hypot(1.5, 2.0)
    assert earliest_contact_s(w, w.config.gravity, margin) == pytest.approx(
        (1.0 - _reach(w, a) - _reach(w, b) - margin) / rel, rel=1e-12)


def test_a_box_collider_and_an_overlap(fresh):
    w = fresh
    w.add_box_collider((0.0, 0.0, 0.0), (1.0, 0.1, 1.0))
    b = add_box_body(w, HALF, 1000.0, x=(0.3, 0.5, 0.2))
    margin = w.config.speculative_margin_m
    gap = 0.5 - 0.1 - _reach(w, b) - margin  # above the box's top face
    assert earliest_contact_s(w, w.config.gravity, margin) == pytest.approx(math.sqrt(2.0 * gap / G), rel=1e-12)
    add_box_body(w, HALF, 1000.0, x=(0.3, 0.5 + 1.5 * _reach(w, b), 0.2))  # bounding spheres overlap
    assert earliest_contact_s(w, w.config.gravity, margin) == 0.0


def test_a_world_without_bodies_or_motion_has_no_contact_to_come(fresh):
    w = fresh
    assert earliest_contact_s(w, w.config.gravity, 0.0) == math.inf
    add_box_body(w, HALF, 1000.0, x=(0.0, 1.0, 0.0))
    add_box_body(w, HALF, 1000.0, x=(1.0, 1.0, 0.0))
    assert earliest_contact_s(w, w.config.gravity, 0.0) == math.inf  # they fall side by side
