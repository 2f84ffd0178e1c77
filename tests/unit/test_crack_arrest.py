"""sph.algorithm1.arrest_lengths / stress_intensity: how far a crack runs by linear elastic fracture
mechanics (sph/cracks.py step 7, docs/decisions.md "Crack arrest").

Known answers: the weight-function integral gives sigma sqrt(pi a) for a uniform stress and
2 sigma_0 sqrt(a / pi) arcsin(c / a) for a stress sigma_0 on the first c of the crack; K is linear in
the force, so the force at which a crack starts to run scales as K_Ic = sqrt(E G_c); a glass pane
whose bending field drives the crack beyond Eq. 11's length breaks to its edge, and the pieces part.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.fragments import apply_cracks
from geometry.particles import tet_edge
from sph.algorithm1 import stress_intensity
from sph.cracks import threshold_speed
from tests.unit.test_crack_scheme import THICK, analyse, build_pane, glass


@pytest.fixture(scope="module")
def pane():
    return build_pane()


def test_uniform_stress_gives_sigma_sqrt_pi_a():
    a = np.geomspace(1e-3, 0.3, 48)
    K = stress_intensity(a, np.full(a.size, 3.0e7))
    assert np.allclose(K, 3.0e7 * np.sqrt(math.pi * a), rtol=1e-12)


def test_stress_on_the_first_part_of_the_crack():
    """sigma_0 over x < c, none beyond: K(a) = 2 sigma_0 sqrt(a / pi) arcsin(c / a) for a > c (Tada)."""
    a = np.geomspace(1e-3, 0.3, 400)
    c = 0.02
    opening = np.where(a <= c, 1.0e7, 0.0)
    K = stress_intensity(a, opening)
    far = a > 2.0 * c
    exact = 2.0e7 * np.sqrt(a[far] / math.pi) * np.arcsin(c / a[far])
    assert np.allclose(K[far], exact, rtol=0.03)  # the step is resolved to a grid cell (1.4% of a)
    assert np.all(np.diff(K[far]) < 0.0)  # beyond the loaded part K falls: such a crack arrests


def test_the_force_that_drives_a_crack_scales_with_the_toughness(pane):
    """K is linear in the contact force, so a crack runs (arrest length > 0) from the force at which
    K reaches K_Ic = sqrt(E G_c): four times the toughness G_c needs twice the force."""

    def running_force(Gc: float) -> float:
        mat = glass(toughness=Gc)
        lo, hi = threshold_speed(*analyse(pane, 1.0, material=mat)), 200.0
        assert analyse(pane, hi, material=mat)[0].arrest_length.max() > 0.0
        if analyse(pane, lo * 1.0001, material=mat)[0].arrest_length.max() > 0.0:
            pytest.fail(f"G_c = {Gc}: the crack runs from the threshold on; choose a tougher material")
        while hi - lo > 1e-6 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if analyse(pane, mid, material=mat)[0].arrest_length.max() > 0.0 else (mid, hi)
        return analyse(pane, hi, material=mat)[0].hertz.force

    F1, F4 = running_force(1000.0), running_force(4000.0)
    assert F4 / F1 == pytest.approx(2.0, rel=1e-4)


def test_a_bent_glass_pane_breaks_to_its_edge(pane):
    """Soda-lime glass (G_c 8 J/m^2) struck at 1.5x its threshold: Eq. 11 alone (its energy weighted by
    the contact area over a tet face) would stop each crack within the pane, but the plate's bending
    keeps K above K_Ic, so each crack runs to the pane's reach (the energy U'_g / (G_c B) pays for
    more) and the pane parts into one piece per crack sector."""
    mat = glass(toughness=8.0)
    v = 1.5 * threshold_speed(*analyse(pane, 1.0, material=mat))
    an, imp = analyse(pane, v, material=mat)
    ps = pane.particles
    e_near = float(tet_edge(ps.volume[an.nearest]))
    eq11 = an.hertz.area / (math.sqrt(3.0) / 4.0 * e_near**2) * an.energy_available / (mat.toughness * THICK)
    reach = float((np.linalg.norm(ps.centroid - imp.point, axis=1) + tet_edge(ps.volume)).max())
    assert an.fired.all() and np.all(eq11 < 0.5 * reach)
    assert np.all(an.energy_available / (mat.toughness * THICK) > reach)
    assert np.allclose(an.arrest_length, reach) and np.allclose(an.r_outer, reach)
    out, rep = apply_cracks(ps, an.cracks, mode="basic")
    sizes = np.bincount(rep.labels[rep.labels >= 0])
    assert (sizes > 0.05 * ps.alive.sum()).sum() == len(an.cracks)
