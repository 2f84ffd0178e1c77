"""Free flight: symplectic Euler under gravity, and torque-free tumbling (angular momentum, energy,
the intermediate-axis flip against an independent ODE solution of Euler's equations)."""

from __future__ import annotations

import numpy as np
import pytest

from rigid.bodies import add_box_body
from rigid.quat import quat_to_matrix

G = 9.81
DT = 1.0 / 240.0


def test_free_fall_matches_discrete_and_continuous_formulas(fresh):
    w = fresh
    y0, v0 = 10.0, 1.5
    b = add_box_body(w, [0.1, 0.1, 0.1], 1000.0, x=(0.0, y0, 0.0), v=(0.0, v0, 0.0))
    m = w.config.substeps
    h = DT / m  # the integrator's step: each step is m symplectic-Euler substeps
    for n in range(1, 241):
        w.step(DT)
        st = w.body_state()
        t = n * DT
        k = n * m
        # symplectic Euler (velocity first) over k substeps of h:
        #   v_k = v0 - k g h,   y_k = y0 + k h v0 - g h^2 k (k + 1) / 2
        y_disc = y0 + k * h * v0 - G * h * h * k * (k + 1) / 2
        assert st.v[b, 1] == pytest.approx(v0 - k * G * h, abs=256 * np.finfo(float).eps * (1 + G * t))
        assert abs(st.x[b, 1] - y_disc) <= 256 * np.finfo(float).eps * y0
        # continuous: the scheme lags by exactly g h t / 2
        y_cont = y0 + v0 * t - 0.5 * G * t * t
        assert y_cont - st.x[b, 1] == pytest.approx(0.5 * G * h * t, rel=1e-6, abs=1e-12)
        np.testing.assert_array_equal(st.x[b, [0, 2]], 0.0)
        assert not st.asleep[b]


def _euler_reference(inertia, w0_body, t_end):
    """Euler's equations I dw/dt = (I w) x w in the principal frame (scipy, tight tolerance)."""
    from scipy.integrate import solve_ivp

    i1, i2, i3 = inertia

    def rhs(_t, w):
        return [(i2 - i3) * w[1] * w[2] / i1, (i3 - i1) * w[2] * w[0] / i2, (i1 - i2) * w[0] * w[1] / i3]

    return solve_ivp(rhs, (0, t_end), w0_body, rtol=1e-11, atol=1e-13, dense_output=True)


def test_tumbling_box_keeps_angular_momentum_and_flips(fresh):
    w = fresh
    w.config.gravity = (0.0, 0.0, 0.0)
    w.config.sleep_enabled = False
    h = np.array([0.15, 0.10, 0.05])  # principal moments ascending along x, y, z: y is intermediate
    w0 = np.array([0.01, 5.0, 0.01])  # near the intermediate axis
    b = add_box_body(w, h, 1000.0, x=(0.0, 2.0, 0.0), w=w0)
    inertia = w.body_inertia(b)
    moments = np.diag(inertia)
    l0 = inertia @ w0
    e0 = 0.5 * w0 @ inertia @ w0
    t_end = 6.0
    ref = _euler_reference(moments, w0, t_end)
    wy_body, ts, lerr, erise = [], [], 0.0, 0.0
    for n in range(1, int(t_end / DT) + 1):
        w.step(DT)
        st = w.body_state()
        rot = quat_to_matrix(st.q[b])
        i_world = rot @ inertia @ rot.T
        lw = i_world @ st.w[b]
        lerr = max(lerr, np.linalg.norm(lw - l0) / np.linalg.norm(l0))
        erise = max(erise, (0.5 * st.w[b] @ i_world @ st.w[b]) / e0 - 1.0)
        wy_body.append((rot.T @ st.w[b])[1])
        ts.append(n * DT)
    wy_body, ts = np.array(wy_body), np.array(ts)
    assert lerr < 0.005, f"angular momentum drift {lerr:.2e}"
    assert lerr < 1e-10  # the DLM splitting keeps L to round-off
    assert erise < 0.005, f"kinetic energy rose by {erise:.2e}"
    # it flips: the intermediate-axis component changes sign, when Euler's equations say it does
    flip = ts[np.argmax(wy_body < 0)]
    ref_flip = ts[np.argmax(ref.sol(ts)[1] < 0)]
    assert wy_body.min() < -0.9 * w0[1]
    print(f"flip at {flip:.4f} s, Euler reference {ref_flip:.4f} s, L err {lerr:.1e}, E rise {erise:.1e}")
    assert flip == pytest.approx(ref_flip, rel=0.03), (flip, ref_flip)


def test_spin_about_a_principal_axis_is_steady(fresh):
    w = fresh
    w.config.gravity = (0.0, 0.0, 0.0)
    w.config.sleep_enabled = False
    b = add_box_body(w, [0.15, 0.10, 0.05], 500.0, x=(0.0, 0.0, 0.0), w=(0.0, 0.0, 7.0), v=(1.0, 0.0, 0.0))
    for _ in range(480):
        w.step(DT)
    st = w.body_state()
    np.testing.assert_allclose(st.w[b], [0.0, 0.0, 7.0], atol=1e-9)
    np.testing.assert_allclose(st.x[b], [480 * DT, 0.0, 0.0], atol=1e-12)
    angle = 7.0 * 480 * DT
    np.testing.assert_allclose(quat_to_matrix(st.q[b])[:2, 0], [np.cos(angle), np.sin(angle)], atol=1e-9)
