"""sph.contact Hertz impact: textbook numbers against independent solutions of the defining equations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from core.errors import ConfigError
from sph.contact import (
    HERTZ_DURATION_CONST,
    effective_modulus,
    hertz_impact,
    hertz_max_tension,
    hertz_threshold_speed,
    speed_for_force,
)

# steel ball, 1 cm radius, on a glass half-space (Johnson 1985 Sect. 11.4 example type)
RHO_STEEL, E_STEEL, NU_STEEL = 7850.0, 2.1e11, 0.30
E_GLASS, NU_GLASS = 7.0e10, 0.22
R_BALL = 0.01
M_BALL = RHO_STEEL * 4.0 / 3.0 * math.pi * R_BALL**3


def _independent(m_eff: float, R_eff: float, E_eff: float, v: float) -> dict:
    """delta from the energy balance (root finding), F, a from their definitions, the duration by
    integrating m* x'' = -4/3 E* sqrt(R*) x^(3/2) until the bodies separate."""
    k = 4.0 / 3.0 * E_eff * math.sqrt(R_eff)
    def balance(d: float) -> float:
        return 0.5 * m_eff * v * v - 8.0 / 15.0 * E_eff * math.sqrt(R_eff) * d**2.5

    delta = brentq(balance, 0.0, 1.0, xtol=1e-300, rtol=1e-14)

    def rhs(_t, y):
        return [y[1], -k * max(y[0], 0.0) ** 1.5 / m_eff]

    def separate(_t, y):
        return y[0]

    separate.terminal = True
    separate.direction = -1
    t_guess = 10.0 * delta / v
    sol = solve_ivp(rhs, (0.0, t_guess), [0.0, v], events=separate, rtol=1e-11, atol=1e-16 * delta,
                    max_step=t_guess / 2000)
    t_end = float(sol.t_events[0][-1])
    return {"delta": delta, "force": k * delta**1.5, "a": math.sqrt(R_eff * delta), "duration": t_end,
            "x_max": float(np.max(sol.y[0])), "v_out": float(sol.y_events[0][-1][1])}


def test_steel_ball_on_glass_matches_the_defining_equations(capsys):
    v = 1.0
    hz = hertz_impact(M_BALL, math.inf, R_BALL, math.inf, E_GLASS, NU_GLASS, E_STEEL, NU_STEEL, v)
    E_eff = 1.0 / ((1 - NU_GLASS**2) / E_GLASS + (1 - NU_STEEL**2) / E_STEEL)
    assert hz.E_eff == pytest.approx(E_eff, rel=1e-14)
    assert hz.m_eff == M_BALL and hz.R_eff == R_BALL
    ref = _independent(M_BALL, R_BALL, E_eff, v)
    assert hz.delta == pytest.approx(ref["delta"], rel=1e-10)
    assert hz.force == pytest.approx(ref["force"], rel=1e-10)
    assert hz.radius_a == pytest.approx(ref["a"], rel=1e-10)
    assert hz.area == pytest.approx(math.pi * ref["a"] ** 2, rel=1e-10)
    assert hz.duration == pytest.approx(ref["duration"], rel=2e-5)
    assert ref["x_max"] == pytest.approx(hz.delta, rel=1e-6)  # the ODE reaches the same max approach
    assert ref["v_out"] == pytest.approx(-v, rel=1e-6)  # elastic: leaves with the same speed
    assert hz.p0 == pytest.approx(3.0 * hz.force / (2.0 * math.pi * hz.radius_a**2), rel=1e-12)
    with capsys.disabled():
        print(
            f"\n[Hertz] steel ball R = 1 cm (m = {M_BALL * 1e3:.2f} g) at 1 m/s on glass: E* = {E_eff / 1e9:.2f} GPa, "
            f"delta = {hz.delta * 1e6:.2f} um, F = {hz.force:.1f} N, a = {hz.radius_a * 1e3:.3f} mm, "
            f"p0 = {hz.p0 / 1e9:.3f} GPa, t = {hz.duration * 1e6:.2f} us (ODE {ref['duration'] * 1e6:.2f} us)"
        )


def test_duration_constant():
    """t = 2 (d/v) int_0^1 dx / sqrt(1 - x^(5/2)) = 2.9432 d/v (Johnson's 2.94)."""
    integral, _ = quad(lambda s: 1.0 / math.sqrt(1.0 - s**2.5), 0.0, 1.0, limit=200)
    assert HERTZ_DURATION_CONST == pytest.approx(2.0 * integral, rel=1e-9)
    assert HERTZ_DURATION_CONST == pytest.approx(2.9432, abs=1e-4)


def test_two_finite_spheres():
    """Two balls of different size, mass and material: effective quantities and the same balance."""
    m1, m2, R1, R2 = 0.2, 0.05, 0.03, 0.012
    hz = hertz_impact(m1, m2, R1, R2, 6e10, 0.25, 2e11, 0.29, 3.0)
    m_eff = m1 * m2 / (m1 + m2)
    R_eff = R1 * R2 / (R1 + R2)
    E_eff = effective_modulus(6e10, 0.25, 2e11, 0.29)
    ref = _independent(m_eff, R_eff, E_eff, 3.0)
    assert hz.m_eff == pytest.approx(m_eff, rel=1e-14)
    assert hz.R_eff == pytest.approx(R_eff, rel=1e-14)
    assert hz.force == pytest.approx(ref["force"], rel=1e-10)
    assert hz.duration == pytest.approx(ref["duration"], rel=2e-5)


def test_power_laws_in_speed():
    """F ~ v^(6/5), a ~ v^(2/5), p0 ~ v^(2/5), t ~ v^(-1/5)."""
    h1 = hertz_impact(M_BALL, math.inf, R_BALL, math.inf, E_GLASS, NU_GLASS, E_STEEL, NU_STEEL, 1.0)
    h2 = hertz_impact(M_BALL, math.inf, R_BALL, math.inf, E_GLASS, NU_GLASS, E_STEEL, NU_STEEL, 7.0)
    assert h2.force / h1.force == pytest.approx(7.0**1.2, rel=1e-12)
    assert h2.radius_a / h1.radius_a == pytest.approx(7.0**0.4, rel=1e-12)
    assert h2.p0 / h1.p0 == pytest.approx(7.0**0.4, rel=1e-12)
    assert h2.duration / h1.duration == pytest.approx(7.0**-0.2, rel=1e-12)
    assert speed_for_force(h2.force, h2.m_eff, h2.R_eff, h2.E_eff) == pytest.approx(7.0, rel=1e-12)


def test_hertz_threshold_speed_and_its_scaling():
    """Bisection on (1 - 2 nu)/3 p0(v) = sigma_t matches the closed form; v_th ~ sigma_t^(5/2) E*^-2."""
    sig = 5e7

    def tension(v: float, E1: float = E_GLASS) -> float:
        hz = hertz_impact(M_BALL, math.inf, R_BALL, math.inf, E1, NU_GLASS, math.inf, 0.3, v)
        return hertz_max_tension(hz, NU_GLASS)

    v_th = hertz_threshold_speed(M_BALL, math.inf, R_BALL, math.inf, E_GLASS, NU_GLASS, math.inf, 0.3, sig)
    v_bis = brentq(lambda v: tension(v) - sig, 1e-12, 100.0, xtol=1e-16, rtol=1e-13)
    assert v_th == pytest.approx(v_bis, rel=1e-9)
    v2 = hertz_threshold_speed(M_BALL, math.inf, R_BALL, math.inf, E_GLASS, NU_GLASS, math.inf, 0.3, 2 * sig)
    assert v2 / v_th == pytest.approx(2.0**2.5, rel=1e-9)
    v3 = hertz_threshold_speed(M_BALL, math.inf, R_BALL, math.inf, 2 * E_GLASS, NU_GLASS, math.inf, 0.3, sig)
    assert v3 / v_th == pytest.approx(2.0**-2, rel=1e-9)  # rigid collider: E* doubles with E1


@pytest.mark.parametrize(
    "args",
    [
        (-1.0, math.inf, 0.01, math.inf, 7e10, 0.2, 2e11, 0.3, 1.0),
        (0.1, math.inf, math.inf, math.inf, 7e10, 0.2, 2e11, 0.3, 1.0),
        (0.1, math.inf, 0.01, math.inf, 7e10, 0.5, 2e11, 0.3, 1.0),
        (0.1, math.inf, 0.01, math.inf, math.inf, 0.2, 2e11, 0.3, 1.0),
        (0.1, math.inf, 0.01, math.inf, 7e10, 0.2, 2e11, 0.3, float("nan")),
        (0.1, 0.0, 0.01, math.inf, 7e10, 0.2, 2e11, 0.3, 1.0),
    ],
)
def test_bad_input_is_rejected(args):
    with pytest.raises(ConfigError):
        hertz_impact(*args)
