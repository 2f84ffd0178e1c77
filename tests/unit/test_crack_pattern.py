"""The crack PATTERN of Algorithm 1 (Sect. 4.2, Fig. 2, 9), against known answers:

- a plate struck at its centre: N radial cracks spread around the point (a cobweb), for N = 1..8;
- the crack normals follow the principal directions of the analytic field Algorithm 1 uses;
- the struck surface's own normal, not the collision spheres', frames the analysis (an oblique or
  off-axis contact leans the pattern, it does not fold it to one side);
- a rod struck sideways breaks by bending, with a threshold speed within a factor 2 of beam theory;
- the number of pieces rises with speed and N and falls with strength and toughness;
- cracks = "auto": the radial-crack count grows as the square root of the impact speed.

Pane: soda-lime glass 0.3 x 0.3 x 0.008 m, tets at 1 cm, isotropic kernels of 2 cm support, struck at
its centre by a 1 cm steel ball. Material values: E = 70 GPa, nu = 0.22, G_c = K_Ic^2/E with
K_Ic = 0.75 MPa m^0.5 (8 J/m^2), strength 40 MPa (Wiederhorn 1969; Ashby & Jones, Engineering Materials).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.study_pattern import (
    GLASS_GC,
    GLASS_SIGMA,
    THICK,
    glass,
    pieces,
    pmma,
    rod_threshold_from_beam_theory,
    side_gaps,
    strike,
    strike_rod,
)
from bench.study_pattern import pane as make_pane
from bench.study_pattern import rod as make_rod
from sim.struck_surface import surface_frame
from sph.cracks import threshold_speed


@pytest.fixture(scope="module")
def pane():
    return make_pane()


@pytest.fixture(scope="module")
def rod():
    return make_rod()


def in_plane_angle(v: np.ndarray) -> float:
    return math.degrees(math.atan2(float(v[1]), float(v[0]))) % 360.0


@pytest.mark.parametrize("N", range(1, 9))
def test_plate_struck_at_its_centre_makes_a_cobweb(pane, N):
    """N groups -> N radial cracks around the point: each crack plane contains the plate normal, each
    half-disc runs along its group's bisector, the half-discs cover the circle (largest angular gap
    < 2 x 360/N) and no two run the same way (an even N pairs opposite half-discs into one line)."""
    v = 3.0 * threshold_speed(strike(pane, 1.0, N))
    an = strike(pane, v, N)
    assert an.field == "plate" and len(an.cracks) == N and an.fired.all()
    for crack in an.cracks:
        assert abs(float(crack.normal @ np.array([0.0, 0.0, 1.0]))) < 1e-6  # radial: the plane holds n
    if N == 1:
        assert an.cracks[0].side is None  # one group: a full disc through the point
        return
    gaps = side_gaps(an)
    assert gaps.max() < 2.0 * 360.0 / N, gaps
    assert gaps.min() > 0.5 * 360.0 / N, gaps
    # each crack runs inside its own group's sector (a 1 cm lattice of tets leans it off the bisector)
    for crack, k in zip(an.cracks, np.flatnonzero(an.fired)):
        assert math.degrees(math.acos(min(1.0, float(crack.side @ an.bisector[k])))) < 180.0 / N


def test_crack_normals_follow_the_analytic_principal_directions(pane):
    """The SPH gradient (Eq. 7 with the quadratic correction) of the plate field gives the same crack
    normals as the field's exact gradient (the principal directions of the analytic field, averaged over
    each group as Algorithm 1 averages), within 10 degrees."""
    v = 3.0 * threshold_speed(strike(pane, 1.0, 6))
    sph = strike(pane, v, 6)
    exact = strike(pane, v, 6, gradient="analytic")
    assert sph.fired.all() and exact.fired.all()
    for k in range(6):
        cos = abs(float(sph.principal_dir[k] @ exact.principal_dir[k]))
        assert math.degrees(math.acos(min(1.0, cos))) < 10.0


def test_surface_frame_takes_the_struck_face_not_the_contact_normal(pane):
    """The collision spheres report a normal 30 degrees off the pane and a point 4 cm in front of it,
    1.5 cm off the striker's axis: the analysis frame is the pane's own face normal and the foot of the
    striker's centre on that face."""
    ps = pane.particles
    tilt = math.radians(30.0)
    reported_n = np.array([math.sin(tilt), 0.0, -math.cos(tilt)])
    point, normal = surface_frame(ps, 0, np.array([0.035, 0.0, 0.044]), reported_n, 0.02,
                                  striker=np.array([0.02, 0.01, 0.03]))
    assert normal == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    assert point == pytest.approx([0.02, 0.01, 0.5 * THICK], abs=1e-12)
    # without a striker (a collider), the reported point is projected onto the face
    point, _ = surface_frame(ps, 0, np.array([0.035, 0.0, 0.044]), reported_n, 0.02)
    assert point == pytest.approx([0.035, 0.0, 0.5 * THICK], abs=1e-12)


@pytest.mark.parametrize("tilt_deg", [76.0, 80.0, 84.0, 30.0])
def test_surface_frame_keeps_the_floor_normal_where_an_edge_bears_the_blow(tilt_deg):
    """A 2 cm disc (the Tai Chi ornament's, 12 mm tets) landing on the edge between its rim and a face,
    tilted 6-14 or 60 degrees off upright: the faces within one tet edge of the contact belong to both
    surfaces, so there is no surface normal there and the analysis frame is the floor's (the load's)
    normal, whatever mix of faces lies near. Standing upright on its rim (a smooth, faceted cylinder)
    the frame is the rim's own normal, within the facets' 7.5 degrees (12 mm tets on a 10 cm radius)."""
    from geometry.build import build_object
    from geometry.particles import tet_edge

    geo = build_object("taichi", shape_params=dict(radius=0.1, height=0.02), resolution=0.012)
    ps = geo.particles
    edge = float(tet_edge(float(np.median(ps.volume))))
    corners = ps.rest_verts.reshape(-1, 3)

    def floor_contact(deg: float):
        t = math.radians(deg)  # the disc's axis is y; turned by t about x, it lands on the floor (+y up)
        inward = np.array([0.0, math.cos(t), -math.sin(t)])  # the floor's normal in the disc's frame
        return corners[int(np.argmin(corners @ inward))], inward

    point, inward = floor_contact(tilt_deg)
    _, normal = surface_frame(ps, 0, point, inward, edge)
    assert normal == pytest.approx(inward, abs=1e-12)
    point, inward = floor_contact(90.0)
    _, normal = surface_frame(ps, 0, point, inward, edge)
    rim = math.degrees(math.acos(min(1.0, float(normal @ inward))))
    assert 0.0 < rim < 7.5


# ----------------------------------------------------------------------------- a rod struck sideways


@pytest.mark.parametrize("stretch", [1.0, 3.0])
def test_rod_struck_sideways_breaks_by_bending(rod, stretch):
    """Isotropic and axis-stretched kernels (the issue's case): the analysis sees the tension on the
    far side, the crack plane is across the rod (normal along the axis, within 10 degrees), and the
    threshold speed is within a factor 2 of the beam-theory estimate; no crack at 0.8 of it, cracks
    at 1.25 of it."""
    probe = strike_rod(rod, 10.0, stretch)
    assert probe.field == "beam"
    v_th = threshold_speed(probe)
    v_beam = rod_threshold_from_beam_theory(float(rod.particles.mass.sum()))
    assert 0.5 < v_th / v_beam < 2.0, (v_th, v_beam)
    assert not strike_rod(rod, 0.8 * v_th, stretch).fired.any()
    above = strike_rod(rod, 1.25 * v_th, stretch)
    assert above.fired.any()
    for crack in above.cracks:
        assert abs(float(crack.normal[1])) > math.cos(math.radians(10.0))


# ----------------------------------------------------------------------------- counts and the auto law


def monotone(values, rising: bool) -> bool:
    d = np.diff(values) if rising else -np.diff(values)
    return bool(np.all(d >= 0) and d.sum() > 0)


def test_pieces_rise_with_speed_and_n_and_fall_with_strength_and_toughness(pane):
    v_th = threshold_speed(strike(pane, 1.0, 4))
    by_speed = [pieces(pane, strike(pane, f * v_th, 4)) for f in (1.2, 2.0, 4.0)]
    # fast enough for all 8 cracks' Eq. 11 radii to reach the edge (at 4 v_th they share too little energy)
    by_n = [pieces(pane, strike(pane, 6.0 * v_th, n)) for n in (2, 4, 8)]
    # at 4 v_th the peak tension is about 3 sigma_t: a 5x stronger glass (200 MPa, still glass) holds
    by_strength = [pieces(pane, strike(pane, 4.0 * v_th, 4, material=glass(sigma_t=s)))
                   for s in (GLASS_SIGMA, 2.0 * GLASS_SIGMA, 5.0 * GLASS_SIGMA)]
    by_toughness = [pieces(pane, strike(pane, 4.0 * v_th, 4, material=glass(toughness=g)))
                    for g in (GLASS_GC, 2 * GLASS_GC, 4 * GLASS_GC)]
    assert monotone(by_speed, True), by_speed
    assert monotone(by_n, True), by_n
    assert monotone(by_strength, False), by_strength
    assert monotone(by_toughness, False), by_toughness


def test_auto_crack_count_grows_as_the_square_root_of_speed():
    """cracks = "auto" on a 1 mm PMMA plate (E 3 GPa, rho 1180, K_Ic 1 MPa m^0.5: G_c 333 J/m^2):
    about 4 radial cracks at 22 m/s, as Vandenberghe et al. (2013) counted; the count follows
    N ~ V^(1/2) (log-log slope 0.5 +- 0.1) over a 64x range of speed, and falls with toughness."""
    plate = make_pane(thickness=0.001, resolution=0.005)  # tets at most 5x as wide as the plate is thick
    speeds = np.array([5.0, 20.0, 80.0, 320.0])

    def n_groups(v: float, material=None) -> int:
        return int(strike(plate, float(v), "auto", material=material or pmma(), point=(0.001, 0.002, 0.0005))
                   .members.size)

    n = np.array([n_groups(v) for v in speeds])
    slope = np.polyfit(np.log(speeds), np.log(n), 1)[0]
    assert abs(slope - 0.5) < 0.1, n
    assert 3 <= n_groups(22.2) <= 5
    assert n_groups(80.0, pmma(toughness=4 * 333.0)) < n_groups(80.0)
