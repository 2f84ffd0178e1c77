"""sph.cracks.material_crossings (Sect. 6, Fig. 12): where a crack reaches another material."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.build import build_object
from geometry.cutting import Crack, ShatterField
from sph.cracks import material_crossings, stop_at_crossings


@pytest.fixture(scope="module")
def two_material_plate():
    """A plate 0.2 x 0.1 x 0.01 m; material 0 where x < 0.03, material 1 beyond."""
    obj = build_object("pane", shape_params=dict(size=[0.2, 0.1, 0.01]), resolution=0.008)
    x = obj.particles.centroid
    mat = (x[:, 0] >= 0.03).astype(np.int32)
    spacing = float(np.median(obj.particles.radius)) * 2.0
    return x, mat, spacing


def test_half_disc_towards_the_interface_finds_it(two_material_plate):
    x, mat, spacing = two_material_plate
    crack = Crack(point=[-0.05, 0.0, 0.0], normal=[0.0, 1.0, 0.0], r_outer=0.2, side=[1.0, 0.0, 0.0])
    found = material_crossings(x, mat, crack, band=spacing)
    assert found, "the crack runs into material 1"
    first = found[0]
    assert first.material == 1 and mat[first.particle] == 1
    assert first.distance == pytest.approx(0.08, abs=1.5 * spacing)  # the interface is 8 cm away
    assert abs(float((first.point - crack.point) @ crack.normal)) < 1e-12  # on the crack plane
    assert [c.distance for c in found] == sorted(c.distance for c in found)
    stopped = stop_at_crossings(crack, found)
    assert stopped.r_outer == pytest.approx(first.distance)
    assert np.array_equal(stopped.side, crack.side) and np.array_equal(stopped.normal, crack.normal)
    # the shatter zone and its crushed core stay (within the shortened crack), whatever they were
    for r_inner, r_crush in ((0.03, 0.02), (0.2, 0.15)):
        zone = stop_at_crossings(Crack(point=crack.point, normal=crack.normal, r_outer=0.2, side=crack.side,
                                       r_inner=r_inner, r_crush=r_crush, source="c"), found)
        assert zone.r_inner == pytest.approx(min(r_inner, first.distance))
        assert zone.r_crush == pytest.approx(min(r_crush, zone.r_inner)) and zone.source == "c"
    # a shatter field (each particle by its size) is capped there too: no particle beyond it is freed
    field = ShatterField(support=0.5, level=0.01, edge=0.01)
    capped = stop_at_crossings(Crack(point=crack.point, normal=crack.normal, r_outer=0.2, side=crack.side,
                                     r_inner=0.3, shatter=field), found).shatter
    assert capped.cap == pytest.approx(first.distance)
    assert capped.radius(1e-3) == pytest.approx(first.distance) and first.distance < field.radius(1e-3)


def test_half_disc_away_from_the_interface_finds_nothing(two_material_plate):
    x, mat, spacing = two_material_plate
    crack = Crack(point=[-0.05, 0.0, 0.0], normal=[0.0, 1.0, 0.0], r_outer=0.2, side=[-1.0, 0.0, 0.0])
    assert material_crossings(x, mat, crack, band=spacing) == []
    assert stop_at_crossings(crack, []) is crack


def test_short_crack_and_other_side(two_material_plate):
    """A crack that ends before the interface finds nothing; one started in material 1 finds 0."""
    x, mat, spacing = two_material_plate
    short = Crack(point=[-0.05, 0.0, 0.0], normal=[0.0, 1.0, 0.0], r_outer=0.05)
    assert material_crossings(x, mat, short, band=spacing) == []
    back = Crack(point=[0.08, 0.0, 0.0], normal=[0.0, 1.0, 0.0], r_outer=0.2)
    found = material_crossings(x, mat, back, band=spacing)
    assert found and all(c.material == 0 for c in found)
    assert found[0].distance == pytest.approx(0.05, abs=1.5 * spacing)
    assert np.all(x[[c.particle for c in found], 0] < 0.03)
