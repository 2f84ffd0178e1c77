"""Crack planes closer than a particle are one crack (geometry/crack_merge.py), and a crack through a thin
wall runs through its whole thickness (sph.algorithm1.crack_sides).

Known answers: a box cut by one plane falls into exactly two pieces, of the volumes on either side; two
cracks two degrees apart through the same point are one plane at a 10 cm tet size (they part by 3.5 cm at
the box's side), so they must give those two pieces and no sliver, while cracks 30 degrees apart stay two
planes.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from geometry.crack_merge import merge_coincident
from geometry.cutting import Crack
from geometry.fragments import apply_cracks, fragment_volumes
from tests.unit.test_cut_meshes import kuhn_box, particles

EDGE = 0.1  # m: the Kuhn box's cell size below (10 cells over 1 m)


def tilted(deg: float) -> np.ndarray:
    """The unit normal z turned by `deg` degrees about y."""
    a = math.radians(deg)
    return np.array([math.sin(a), 0.0, math.cos(a)])


@pytest.fixture(scope="module")
def box():
    return particles(kuhn_box(10, 10, 4, size=(1.0, 1.0, 0.4), jitter=0.1, seed=3))


P_MID = [0.5, 0.5, 0.25]  # m: between the box's vertex layers (no vertex snapped onto the plane)


def disc_and_half(deg: float) -> list[Crack]:
    """A full-disc crack across the box and a half-disc one through the same point, its normal `deg`
    apart (its region lies within the disc's)."""
    return [Crack(point=P_MID, normal=tilted(0.0), r_outer=1.0),
            Crack(point=P_MID, normal=tilted(deg), r_outer=1.0, side=[1.0, 0.0, 0.0])]


@pytest.mark.parametrize("mode", ["basic", "subdivision"])
def test_planes_two_degrees_apart_cut_as_one(box, mode):
    cracks = disc_and_half(2.0)
    _, raw = apply_cracks(box, cracks, mode=mode)
    merged = merge_coincident(cracks, [EDGE, EDGE])
    (one,) = merged  # the half-disc lies within the disc: one crack, the disc
    assert np.array_equal(one.normal, cracks[0].normal) and one.side is None and one.r_outer == 1.0
    out, rep = apply_cracks(box, merged, mode=mode)
    print(f"\n{mode}: a disc and a half-disc 2 degrees apart give {raw.n_fragments} pieces unmerged, "
          f"{rep.n_fragments} merged")
    assert rep.n_fragments == 2
    assert raw.n_fragments > 2  # the unmerged wedge is thinner than a tet: slivers
    if mode == "subdivision":
        assert fragment_volumes(out, rep.labels) == pytest.approx([0.25, 0.15], rel=1e-9)  # the plane z = 0.25


def test_overlapping_half_discs_share_one_plane_and_leave_no_sliver(box):
    """Half-discs with sides 90 degrees apart (they overlap over a quarter of the plane and leave a quarter
    uncut, so the box holds together), normals 2 degrees apart: one plane, two regions, one piece."""
    cracks = [Crack(point=P_MID, normal=tilted(0.0), r_outer=1.0, side=[1.0, 0.0, 0.0]),
              Crack(point=P_MID, normal=tilted(2.0), r_outer=1.0, side=[0.0, 1.0, 0.0])]
    merged = merge_coincident(cracks, [EDGE, EDGE])
    assert len(merged) == 2 and np.array_equal(merged[1].normal, merged[0].normal)  # both normals +z
    assert merged[1].side == pytest.approx([0.0, 1.0, 0.0])
    _, raw = apply_cracks(box, cracks, mode="subdivision")
    _, rep = apply_cracks(box, merged, mode="subdivision")
    assert raw.n_fragments > 1 and rep.n_fragments == 1


def test_distinct_planes_stay_distinct(box):
    cracks = disc_and_half(30.0)
    merged = merge_coincident(cracks, [EDGE, EDGE])
    assert len(merged) == 2
    assert all(np.array_equal(a.normal, b.normal) for a, b in zip(merged, cracks))
    assert all(np.array_equal(a.point, b.point) for a, b in zip(merged, cracks))


def test_the_tolerance_is_a_tet_edge_over_the_reach():
    """Two full discs of radius r through the same point, normals theta apart, coincide within an edge e
    when r sin(theta) < e (the farthest the tilt takes the region off the other plane)."""
    r, e = 0.2, 0.01
    limit = math.degrees(math.asin(e / r))
    for deg, same in ((0.9 * limit, True), (1.1 * limit, False)):
        a = Crack(point=[0.0, 0.0, 0.0], normal=tilted(0.0), r_outer=r)
        b = Crack(point=[0.0, 0.0, 0.0], normal=tilted(deg), r_outer=r)
        merged = merge_coincident([a, b], [e, e])
        assert len(merged) == (1 if same else 2)  # one disc holds the other: one crack


def test_a_crack_near_an_earlier_events_crack_takes_its_plane():
    old = Crack(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0], r_outer=0.3)
    new = Crack(point=[0.1, 0.0, 0.002], normal=tilted(0.5), r_outer=0.2, side=[1.0, 0.0, 0.0])
    (moved,) = merge_coincident([new], [0.01], history=[old])
    assert np.array_equal(moved.normal, old.normal)
    assert moved.point == pytest.approx([0.1, 0.0, 0.0], abs=1e-15)  # projected onto the old plane
    assert moved.side == pytest.approx([1.0, 0.0, 0.0])
    (turned,) = merge_coincident([replace(new, normal=-new.normal)], [0.01], history=[old])
    assert np.array_equal(turned.normal, -old.normal)  # the same plane, the crack's own orientation kept
    far = Crack(point=[0.1, 0.0, 0.05], normal=[0.0, 0.0, 1.0], r_outer=0.2)  # a parallel plane 5 cm off
    assert merge_coincident([far], [0.01], history=[old])[0] is far


def test_a_pane_struck_on_its_edge_cracks_through_its_thickness():
    """A glass pane (8 mm thick) struck on its edge by a steel ball above the threshold: every crack's
    side lies in the pane (no component across the thickness), so the half-disc holds every depth at
    the contact and the pane parts there."""
    from bench.study_pattern import pane, pieces, strike
    from sph.cracks import threshold_speed

    p = pane()
    hit = dict(point=(0.15, 0.002, 0.001), normal=(-1.0, 0.0, 0.0), reference=(0.0, 1.0, 0.0))
    v_th = threshold_speed(strike(p, 1.0, 3, **hit))
    an = strike(p, 1.25 * v_th, 3, **hit)
    assert an.cracks
    for crack in an.cracks:
        assert abs(float(crack.side[2])) < 1e-3  # the thin axis is measured from the tets: z within 0.06 deg
    assert pieces(p, an) >= 2


def test_a_thin_axis_given_by_the_caller_holds_the_cracks_through_it():
    """A crossing into a second material is analysed on that material's particles alone, where the
    wall can read as thick; it takes the contact's thin axis (ImpactSpec.thin) instead. On the 8 mm
    pane struck on its face and read as a half-space, the cracks lean through the thickness (cone
    facets); given the pane's normal as the thin axis, every side lies in the pane. A thin axis that is
    not a direction is refused with its key."""
    import dataclasses

    from bench.study_pattern import BALL, RES, THICK, glass, pane
    from core.errors import ConfigError
    from sph.cracks import ImpactSpec, analyse_impact, threshold_speed
    from sph.kernel import kernel_isotropic

    ps = pane().particles
    spec = ImpactSpec(point=(0.001, 0.002, 0.5 * THICK), normal=(0.0, 0.0, -1.0), speed=1.0, m1=float(ps.mass.sum()),
                      R1=math.inf, reference=(1.0, 0.0, 0.0), **BALL)

    def strike(s: ImpactSpec):
        G = kernel_isotropic(2 * RES)
        return analyse_impact(ps.centroid, ps.volume, G, glass(), s, 3, THICK, field="halfspace")

    spec = dataclasses.replace(spec, speed=3.0 * threshold_speed(strike(spec)))
    free, held = strike(spec), strike(dataclasses.replace(spec, thin=(0.0, 0.0, 2.0)))
    assert free.cracks and held.cracks and held.thin_axis == pytest.approx([0.0, 0.0, 1.0])
    assert max(abs(float(c.side[2])) for c in free.cracks) > 0.1
    assert all(abs(float(c.side[2])) < 1e-12 for c in held.cracks)
    with pytest.raises(ConfigError, match="impact.thin"):
        dataclasses.replace(spec, thin=(0.0, 0.0, 0.0))


def test_one_analysis_crack_found_twice_is_cut_once(box):
    """Two half-discs of one analysis (one point) running the same way, their planes 8 degrees apart:
    beyond the reach rule (1 m x sin 8 degrees is 1.4 tet edges) but within the analysis' own accuracy
    (DIRECTION_ACCURACY_DEG): one crack, the longer, whose region holds both shatter radii. Cut as two,
    the wedge between them frees slivers; 15 degrees apart they are two cracks."""
    from geometry.crack_merge import DIRECTION_ACCURACY_DEG

    side = [0.0, 1.0, 0.0]  # both planes hold y: the sides run the same way
    a = Crack(point=P_MID, normal=tilted(0.0), r_outer=0.8, side=side, r_inner=0.05)
    b = Crack(point=P_MID, normal=tilted(8.0), r_outer=1.0, side=side)
    assert 8.0 < DIRECTION_ACCURACY_DEG and math.sin(math.radians(8.0)) * b.r_outer > EDGE
    (one,) = merge_coincident([a, b], [EDGE, EDGE])
    assert np.array_equal(one.normal, b.normal) and one.r_outer == 1.0 and one.r_inner == 0.05
    _, raw = apply_cracks(box, [a, b], mode="subdivision")
    _, rep = apply_cracks(box, [one], mode="subdivision")
    assert rep.n_fragments == 1 < raw.n_fragments  # a half-plane cut does not part the box; the wedge frees slivers
    apart = Crack(point=P_MID, normal=tilted(15.0), r_outer=1.0, side=side)
    assert len(merge_coincident([a, apart], [EDGE, EDGE])) == 2
