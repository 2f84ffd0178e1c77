"""sph.cleavage: a material with weak planes (slate's cleavage) fails across them at their own,
lower strength, and its crack then lies on a plane (issue 14 item 7, Fig. 12).

Known answers: under uniaxial tension s along e at an angle theta to the planes' normal a, the single
plane of weakness gives the failure stress min(sigma_t, sigma_c / cos^2 theta) (computed here from
the traction on the plane, independently of the module), with the crack on the plane where the second
governs; a cleavage as strong as the bulk changes nothing; the crack normals of a struck pane turn
onto the cleavage normal and its threshold speed falls; the planes and the stiffness axes turn with
the object's rotation, for the fracture analysis and the elastic effect.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tomllib

from core.errors import MaterialError
from geometry.cutting import Crack
from scenes.loader import scene_from_dict
from sim.world import World
from sph.cleavage import Cleavage, equivalent_tension, opens_on_plane, tension_across
from sph.contact import effective_isotropic
from sph.cracks import threshold_speed
from sph.crossings import MaterialCrossing, carry_on
from sph.materials import Material, material_from_dict, oriented, stiffness_isotropic
from tests.unit.test_crack_scheme import SIGMA_T, analyse, build_pane

SIGMA_C = SIGMA_T / 4.0  # Pa: across the planes (slate: 3-5 MPa against 10-20 MPa along them)
A_IN_PLANE = np.array([math.cos(math.radians(30.0)), math.sin(math.radians(30.0)), 0.0])  # the pane's plane


def slate_like(cleavage_strength: float | None = SIGMA_C, normal=A_IN_PLANE) -> Material:
    """The test glass of test_crack_scheme with weak planes (isotropic stiffness: only the strength
    differs, so every change below comes from the cleavage)."""
    cleavage = None if cleavage_strength is None else dict(normal=list(normal), tensile_strength=cleavage_strength)
    return Material("slate-like", 2500.0, stiffness_isotropic(7e10, 0.22), tensile_strength=SIGMA_T, toughness=10.0,
                    cleavage=cleavage)


@pytest.fixture(scope="module")
def pane():
    return build_pane()


@pytest.mark.parametrize("entry, key, allowed", [
    (dict(tensile_strength=1e6), "cleavage.normal", "required"),
    (dict(normal=[0, 0, 0], tensile_strength=1e6), "cleavage.normal", "non-zero"),
    (dict(normal=[1, 0, 0], tensile_strength=2 * SIGMA_T), "cleavage.tensile_strength", "bulk"),
    (dict(normal=[1, 0, 0], tensile_strength=-1.0), "cleavage.tensile_strength", "0 <"),
    (dict(normal=[1, 0, 0], tensile_strength=1e6, strength=1), "cleavage.strength", "not a key"),
])
def test_bad_cleavage_is_refused_with_its_key(entry, key, allowed):
    d = dict(model="isotropic", E=7e10, nu=0.22, density=2500.0, tensile_strength=SIGMA_T, cleavage=entry)
    with pytest.raises(MaterialError) as err:
        material_from_dict(d, key="materials.slate")
    assert key in str(err.value) and allowed in str(err.value)


@pytest.mark.parametrize("theta_deg", [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0])
def test_uniaxial_strength_is_that_of_a_single_plane_of_weakness(theta_deg):
    theta = math.radians(theta_deg)
    a = np.array([0.0, 0.0, 1.0])
    e = np.array([math.sin(theta), 0.0, math.cos(theta)])
    sigma = np.outer(e, e)[None]  # 1 Pa of uniaxial tension along e
    cleavage = Cleavage(normal=a, tensile_strength=SIGMA_C)
    across = tension_across(sigma, cleavage)
    failure = SIGMA_T / float(equivalent_tension(np.array([1.0]), across, cleavage, SIGMA_T)[0])
    traction = sigma[0] @ a  # the traction on the plane, and its normal part
    expected = min(SIGMA_T, SIGMA_C / max(float(traction @ a), 1e-300))
    assert failure == pytest.approx(expected, rel=1e-12)
    # the crack lies on the plane exactly where the plane fails first (cos^2 theta > sigma_c / sigma_t)
    assert opens_on_plane(float(across[0]), 1.0, cleavage, SIGMA_T) == (math.cos(theta) ** 2 > SIGMA_C / SIGMA_T)


def test_compression_across_the_planes_keeps_them_shut():
    """The Brazilian disc's stress: tension along x, three times as much compression along z; planes
    at 45 degrees see a net compression and do not open, whatever their strength."""
    sigma = np.diag([1.0, 0.0, -3.0])[None]
    cleavage = Cleavage(normal=np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0), tensile_strength=1.0)
    assert tension_across(sigma, cleavage)[0] == 0.0


def test_a_cleavage_as_strong_as_the_bulk_changes_nothing(pane):
    """a . sigma . a never exceeds the largest principal stress, so a plane as strong as the bulk never
    governs: the same cracks, tensions and threshold as without it."""
    without, imp = analyse(pane, 6.0, material=slate_like(None))
    equal, _ = analyse(pane, 6.0, material=slate_like(SIGMA_T))
    assert np.array_equal(without.fired, equal.fired)
    assert np.array_equal(without.tension_per_newton, equal.tension_per_newton)
    assert np.array_equal(without.principal_dir, equal.principal_dir)
    assert threshold_speed(without, imp) == threshold_speed(equal, imp)


def test_a_struck_pane_cracks_on_its_cleavage(pane):
    """The pane's bending tension is nearly equi-biaxial in its plane, so every group's tension across
    planes normal to A_IN_PLANE uses four times more of their strength than of the bulk's: every crack
    lies on the cleavage, and the pane breaks from a lower speed, but not below a quarter of the bulk's
    threshold (the force needed falls at most fourfold, and it grows at least linearly with the
    speed: v^(6/5) for Hertz, v for the pane's bending spring). Both struck at 1.2x the bulk's."""
    imp = analyse(pane, 8.0, material=slate_like(None))[1]
    speed = 1.2 * threshold_speed(analyse(pane, 8.0, material=slate_like(None))[0], imp)
    bulk, imp = analyse(pane, speed, material=slate_like(None))
    weak, _ = analyse(pane, speed, material=slate_like())
    assert weak.fired.any()
    for k in np.flatnonzero(weak.fired):
        assert abs(float(weak.principal_dir[k] @ A_IN_PLANE)) > math.cos(math.radians(0.01))
    turned = [abs(float(bulk.principal_dir[k] @ A_IN_PLANE)) for k in np.flatnonzero(bulk.fired)]
    assert min(turned) < math.cos(math.radians(20.0)), turned  # without it they follow the hoop tension
    v_bulk, v_weak = threshold_speed(bulk, imp), threshold_speed(weak, imp)
    assert SIGMA_C / SIGMA_T * v_bulk <= v_weak < 0.5 * v_bulk


def test_the_planes_turn_with_the_object():
    """Material directions are the object's (like its kernel axes): oriented() turns the stiffness and
    the cleavage normal by the object's rotation, and leaves what does not depend on direction."""
    c, s = math.cos(0.7), math.sin(0.7)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    slate = material_from_dict(dict(model="transverse", axis=[1.0, 0.0, 0.0], E_axial=3e10, E_transverse=8e10,
                                    nu_transverse=0.25, nu_axial=0.2, G_axial=2e10, density=2700.0,
                                    tensile_strength=1.5e7, cleavage=dict(normal=[1.0, 0.0, 0.0],
                                                                          tensile_strength=4e6)))
    turned = oriented(slate, R)
    assert np.allclose(turned.cleavage.normal, R[:, 0], atol=1e-15)
    # the stiffness across the planes (C_aaaa) is still the axial one, wherever they point
    a = turned.cleavage.normal
    strain = np.outer(a, a)
    voigt = np.array([strain[0, 0], strain[1, 1], strain[2, 2], 2 * strain[1, 2], 2 * strain[0, 2], 2 * strain[0, 1]])
    stress_aa = float(a @ _stress_tensor(turned.stiffness @ voigt) @ a)
    assert stress_aa == pytest.approx(float(slate.stiffness[0, 0]), rel=1e-9)
    assert effective_isotropic(turned.stiffness) == pytest.approx(effective_isotropic(slate.stiffness), rel=1e-12)
    assert oriented(slate, np.eye(3)) is slate


def _stress_tensor(v: np.ndarray) -> np.ndarray:
    return np.array([[v[0], v[5], v[4]], [v[5], v[1], v[3]], [v[4], v[3], v[2]]])


def test_a_crack_carries_its_left_energy_into_the_other_material():
    """The parent would have run to 0.2 m and met the other material at 0.05 m: the G_c B 0.15 m it had
    left runs 0.3 m at half the toughness; a longer crack of the new analysis keeps its length; the
    shatter zone stays with the contact."""
    parent = Crack(point=np.zeros(3), normal=[1.0, 0.0, 0.0], r_outer=0.2, side=[0.0, 1.0, 0.0])
    crossing = MaterialCrossing(point=np.array([0.0, 0.05, 0.0]), particle=7, material=1, distance=0.05)
    short = Crack(point=crossing.point, normal=[0.7, 0.7, 0.0], r_outer=0.02, r_inner=0.01)
    long = Crack(point=crossing.point, normal=[0.7, -0.7, 0.0], r_outer=0.5)
    out = carry_on(parent, crossing, [short, long], 20.0, 10.0, "p.crossing.material1")
    assert [c.r_outer for c in out] == [pytest.approx(0.3, rel=1e-12), 0.5]
    assert all(c.r_inner == 0.0 and c.shatter is None and c.source == "p.crossing.material1" for c in out)
    assert np.allclose(out[0].normal, short.normal)


def test_a_turned_object_takes_its_stiffness_axes_along():
    """The wire of Fig. 1 made stiff along its own axis (y, transversely isotropic) and turned 90 degrees
    about z: both the fracture analysis and the elastic effect see the stiff axis along the world's x."""
    raw = tomllib.loads((Path(__file__).resolve().parents[2] / "scenes" / "wire.toml").read_text())
    raw["materials"][0]["stiffness"] = dict(model="transverse", axis=[0.0, 1.0, 0.0], E_axial=6.0e7,
                                            E_transverse=2.0e7, nu_transverse=0.3, nu_axial=0.3, G_axial=8.0e6)
    w = World(scene_from_dict(raw, "wire"))
    try:
        own = w.materials[0].stiffness
        assert own[1, 1] > 2.0 * own[0, 0]  # stiff along the object's own y
        turned = w.object_material(0, 0).stiffness
        assert turned[0, 0] == pytest.approx(own[1, 1], rel=1e-9) and turned[1, 1] == pytest.approx(own[0, 0], rel=1e-9)
        mid = int(w.elastic.sph.particle_mat.to_numpy()[0])
        assert np.array_equal(w.elastic.materials[mid].stiffness, turned)
    finally:
        w.release()
