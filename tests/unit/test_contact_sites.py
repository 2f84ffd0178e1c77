"""A body pair's impact (rigid/records.py `ContactEvents.by_body_pair`): the impulse-weighted mean of its
contacts, and the same over its hardest site (the contact with the largest impulse and those whose spheres
overlap its sphere), which lies where the bodies touch even when the mean does not (a pot landing on its
rim touches the floor on a ring whose centre is in the opening; sim/fracture_stage.py `analyse` takes the
site there)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid.records import ContactEvents

SITE = 0.005  # m: the contact spheres' radius


def events(points, impulses, speeds=None) -> ContactEvents:
    """Contacts of body 0 with the floor (collider 0, normal +y) at `points`, each with its impulse."""
    p = np.asarray(points, np.float64)
    c = len(p)
    ints = np.zeros(c, np.int64)
    return ContactEvents(
        body_a=ints, body_b=ints - 1, sphere_a=np.arange(c), sphere_b=ints - 1, collider=ints,
        point=p, normal=np.tile([0.0, 1.0, 0.0], (c, 1)),
        normal_impulse=np.asarray(impulses, np.float64),
        normal_speed=np.full(c, -3.0) if speeds is None else np.asarray(speeds, np.float64),
        separation=np.zeros(c), site_radius=np.full(c, SITE),
    )


def ring(count: int, radius: float) -> np.ndarray:
    t = 2.0 * math.pi * np.arange(count) / count
    return np.stack([radius * np.cos(t), np.zeros(count), radius * np.sin(t)], 1)


def test_a_compact_patch_keeps_the_impulse_weighted_mean():
    """Nine contacts on a 4 mm grid: the pair's point is their impulse-weighted mean, bit for bit, and
    its hardest site is the contacts within two sphere radii of the hardest one."""
    g = np.arange(3) * 0.004
    pts = np.stack(np.meshgrid(g, [0.0], g, indexing="ij"), -1).reshape(-1, 3)
    imp = np.linspace(1.0, 2.0, 9)
    pair = events(pts, imp).by_body_pair()
    mean = np.stack([np.bincount(np.zeros(9, int), weights=imp * pts[:, k]) for k in range(3)], 1) / imp.sum()
    np.testing.assert_array_equal(pair["point"], mean)
    site = np.linalg.norm(pts - pts[8], axis=1) <= 2 * SITE  # the hardest: the last, at the far corner
    assert 1 < site.sum() < 9
    np.testing.assert_allclose(pair["site_point"][0], imp[site] @ pts[site] / imp[site].sum(), rtol=0, atol=1e-15)
    assert pair["impulse"][0] == pytest.approx(imp.sum())


@pytest.mark.parametrize("hardest", [0, 7, 13])
def test_a_ring_of_contacts_has_its_site_on_the_ring(hardest):
    """A rim of 6 cm radius touching along 48 contacts: their mean is the ring's centre, in the opening;
    the site lies on the ring next to the contact that took the largest impulse, with the contacts'
    normal (unit length)."""
    pts = ring(48, 0.06)  # 7.9 mm apart: the hardest contact's neighbours share its site
    imp = np.full(48, 1.0)
    imp[hardest] = 1.5
    pair = events(pts, imp).by_body_pair()
    assert np.linalg.norm(pair["point"][0]) < 0.02 * 0.06  # the mean: in the opening
    site = pair["site_point"][0]
    assert np.linalg.norm(site - pts[hardest]) < SITE
    assert abs(np.hypot(site[0], site[2]) - 0.06) < 0.1 * SITE  # on the rim, not in the opening
    np.testing.assert_allclose(pair["site_normal"][0], [0.0, 1.0, 0.0], atol=1e-12)
    assert pair["impulse"][0] == pytest.approx(imp.sum())


def test_two_feet_have_their_site_at_the_harder_foot():
    """Two patches 0.2 m apart (a body landing on two feet): the site is the foot of the largest single
    impulse, its point that foot's weighted mean; the pair's speed is the fastest closing of both."""
    foot = np.array([[0.0, 0.0, 0.0], [0.004, 0.0, 0.0], [0.0, 0.0, 0.004]])
    pts = np.concatenate([foot, foot + [0.2, 0.0, 0.0]])
    imp = np.array([1.0, 1.0, 1.0, 2.0, 3.0, 2.0])
    speeds = np.array([-5.0, -5.0, -5.0, -3.0, -3.5, -3.0])
    pair = events(pts, imp, speeds).by_body_pair()
    harder = (imp[3:, None] * pts[3:]).sum(0) / imp[3:].sum()
    np.testing.assert_allclose(pair["site_point"][0], harder, rtol=0, atol=1e-15)
    assert pair["speed"][0] == -5.0
    assert pair["impulse"][0] == pytest.approx(imp.sum())


def test_pairs_are_kept_apart():
    """A ring on one pair and a compact patch on another: each pair's site comes from its own contacts."""
    pts = np.concatenate([ring(12, 0.06), [[1.0, 0.0, 0.0], [1.003, 0.0, 0.0]]])
    ev = events(pts, np.r_[np.ones(12), 1.0, 3.0])
    ev.body_a[12:] = 1
    pair = ev.by_body_pair()
    assert list(pair["body_a"]) == [0, 1]
    assert abs(np.hypot(pair["site_point"][0][0], pair["site_point"][0][2]) - 0.06) < 0.1 * SITE
    np.testing.assert_allclose(pair["site_point"][1], [1.00225, 0.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(pair["point"][1], [1.00225, 0.0, 0.0], rtol=0, atol=1e-12)


def test_sites_only_for_pairs_closing_fast():
    """`site_above`: a pair closing at 3 m/s gets its site above a 2 m/s threshold and NaN above 4 m/s;
    the means do not depend on it."""
    ev = events(ring(12, 0.06), np.ones(12))
    slow, fast = ev.by_body_pair(site_above=4.0), ev.by_body_pair(site_above=2.0)
    assert np.isnan(slow["site_point"]).all() and np.isfinite(fast["site_point"]).all()
    np.testing.assert_array_equal(slow["point"], fast["point"])
