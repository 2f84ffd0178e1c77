"""Algorithm 1 on the paper's pot (geometry.build 'pot', WPCA kernels, Sect. 4.1): the SPH gradient
of the contact field at its particles, and the cracks of a side impact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.build import build_object
from sph.contact import plate_displacement, plate_gradient
from sph.cracks import ImpactSpec, analyse_impact, neighbour_pairs, sph_gradient, threshold_speed
from sph.kernel import kernel_wpca
from sph.materials import Material, stiffness_isotropic

H_WPCA = 0.02  # m: isotropic radius of the WPCA neighbourhood (2 x the pot's 1 cm tets)
PORCELAIN = Material("porcelain", 2400.0, stiffness_isotropic(5e10, 0.2), tensile_strength=4e7, toughness=10.0)


@pytest.fixture(scope="module")
def pot():
    obj = build_object("pot")
    G = kernel_wpca(obj.particles.centroid, H_WPCA)
    c = obj.particles.centroid
    ring = np.flatnonzero(np.abs(c[:, 1] - 0.08) < 0.01)  # the widest ring (outer radius 9 cm at y = 8 cm)
    i = ring[np.argmax(np.hypot(c[ring, 0], c[ring, 2]))]
    radial = np.array([c[i, 0], 0.0, c[i, 2]])
    radial /= np.linalg.norm(radial)
    P = np.array([0.09 * radial[0], c[i, 1], 0.09 * radial[2]])  # on the outer surface
    return obj, G, P, -radial


def _impact(obj, P, n, speed):
    return ImpactSpec(point=P, normal=n, speed=speed, m1=float(obj.particles.mass.sum()), R1=0.09,
                      reference=[0.0, 1.0, 0.0])  # dropped on a stone floor: static, flat, rigid


def test_sph_gradient_on_the_pot(pot, capsys):
    """The plate field around P sampled at the pot's particles with their flat WPCA kernels (3.2 cm
    along the wall, 0.8 cm across): only the quadratic fit resolves it (Bonet-Lok is no better than
    plain SPH here: the field's curvature across a kernel this wide dominates). Errors printed."""
    obj, G, P, n = pot
    x, V = obj.particles.centroid, obj.particles.volume
    frame = np.stack([[0.0, 1.0, 0.0], np.cross(n, [0.0, 1.0, 0.0]), n])
    loc = (x - P) @ frame.T
    d = np.linalg.norm(x - P, axis=1)
    mem = np.flatnonzero(d < 0.04)
    own, nbr = neighbour_pairs(x, G, mem, np.flatnonzero(d < 0.04 + 4 * H_WPCA))
    u = plate_displacement(loc, 1.0, 5e10, 0.2, 0.008, 0.2, 0.005) @ frame
    ga = np.einsum("ai,nab,bj->nij", frame, plate_gradient(loc[mem], 1.0, 5e10, 0.2, 0.008, 0.2, 0.005), frame)
    errs = []
    for order in (0, 1, 2):
        g, _ = sph_gradient(x, V, G, u, mem, own, nbr, order)
        num = (V[mem] * ((g - ga) ** 2).sum(axis=(1, 2))).sum()
        errs.append(math.sqrt(num / (V[mem] * (ga**2).sum(axis=(1, 2))).sum()))
    with capsys.disabled():
        print(f"\n[pot, {len(x)} particles, WPCA h = {H_WPCA} m, {mem.size} particles within 4 cm] plate-field "
              f"gradient rel. L2 error: plain {errs[0]:.3f}, Bonet-Lok {errs[1]:.3f}, quadratic {errs[2]:.3f}")
    assert errs[2] < 0.2 * min(errs[0], errs[1])
    assert errs[2] < 0.1


def test_side_impact_cracks_the_pot_wall(pot):
    obj, G, P, n = pot
    ps = obj.particles
    an0 = analyse_impact(ps.centroid, ps.volume, G, PORCELAIN, _impact(obj, P, n, 1.0), 3, obj.thickness)
    assert an0.field == "plate"  # the wall (8 mm) is thinner than the analysed neighbourhood
    assert an0.plate_thickness == pytest.approx(obj.thickness)
    v_th = threshold_speed(an0, _impact(obj, P, n, 1.0))
    assert 0.0 < v_th < 20.0
    below = analyse_impact(ps.centroid, ps.volume, G, PORCELAIN, _impact(obj, P, n, 0.9 * v_th), 3, obj.thickness)
    assert below.cracks == []
    an = analyse_impact(ps.centroid, ps.volume, G, PORCELAIN, _impact(obj, P, n, 3.0 * v_th), 3, obj.thickness)
    assert len(an.cracks) == 3
    for k, crack in enumerate(an.cracks):
        assert abs(float(crack.normal @ n)) < 1e-9  # radial cracks through the wall
        assert crack.side is not None and float(crack.side @ an.bisector[k]) > 0.5
