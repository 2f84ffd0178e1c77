"""rigid/debris.py: free debris spheres against known answers (free fall, restitution, Coulomb
friction, an oriented box, growing the store without losing a particle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid.debris import MIN_CAPACITY, DebrisStore

G = 9.81  # m/s^2
DT = 1.0 / 240.0  # s


def plane(e: float = 0.5, mu: float = 0.0, y: float = 0.0) -> dict:
    return dict(type="plane", x=[0.0, y, 0.0], normal=[0.0, 1.0, 0.0], restitution=e, friction=mu)


@pytest.fixture()
def store_factory():
    made = []

    def make(colliders, capacity=16):
        s = DebrisStore(capacity, (0.0, -G, 0.0), colliders)
        made.append(s)
        return s

    yield make
    for s in made:
        s.release()


def test_free_fall_is_symplectic_euler_exactly(store_factory):
    """No collider reached: x_n = x_0 + v_0 n dt - g dt^2 n (n + 1) / 2 (v is updated first)."""
    s = store_factory([plane(y=-100.0)])
    s.add([[0.0, 2.0, 0.0], [1.0, 3.0, 0.0]], [[0.5, 0.0, 0.0], [0.0, 1.0, 0.0]], [0.01, 0.02], [7, 9])
    n = 60
    for _ in range(n):
        s.step(DT)
    st = s.state()
    drop = G * DT * DT * n * (n + 1) / 2.0
    assert st["x"][0] == pytest.approx([0.5 * n * DT, 2.0 - drop, 0.0], abs=1e-12)
    assert st["x"][1] == pytest.approx([1.0, 3.0 + n * DT - drop, 0.0], abs=1e-12)
    assert st["v"][1][1] == pytest.approx(1.0 - G * n * DT, abs=1e-12)
    assert st["particle"].tolist() == [7, 9] and st["r"] == pytest.approx([0.01, 0.02])


def test_bounce_returns_restitution_times_the_impact_speed(store_factory):
    e, r, h = 0.5, 0.01, 0.5
    s = store_factory([plane(e=e)])
    s.add([[0.0, h + r, 0.0]], [[0.0, 0.0, 0.0]], [r], [0])
    v_in = math.sqrt(2 * G * h)
    rebound = None
    for _ in range(400):
        v_before = s.state()["v"][0][1]
        s.step(DT)
        v_after = s.state()["v"][0][1]
        if v_before < 0.0 < v_after:
            rebound = v_after
            break
    assert rebound == pytest.approx(e * v_in, rel=0.03)  # within a step's gravity impulse
    assert s.state()["x"][0][1] >= r - 1e-12  # never left inside the floor


def test_coulomb_friction_stops_a_sliding_grain_at_the_expected_distance(store_factory):
    """A grain resting on the floor at 2 m/s sideways, mu = 0.4: d = v^2 / (2 mu g) within a few steps."""
    mu, r, v0 = 0.4, 0.01, 2.0
    s = store_factory([plane(e=0.0, mu=mu)])
    s.add([[0.0, r, 0.0]], [[v0, 0.0, 0.0]], [r], [0])
    for _ in range(480):
        s.step(DT)
    st = s.state()
    assert abs(st["v"][0][0]) < 1e-12
    assert st["x"][0][0] == pytest.approx(v0 * v0 / (2 * mu * G), abs=2 * v0 * DT)


def test_oriented_box_keeps_the_grain_out(store_factory):
    """A box tilted 30 degrees about z: a grain dropped on it never goes inside and slides down."""
    a = math.radians(30.0)
    rot = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    box = dict(type="box", x=[0.0, 0.0, 0.0], half=[0.5, 0.1, 0.5], rot=rot, restitution=0.0, friction=0.0)
    s = store_factory([box])
    s.add([[0.0, 0.3, 0.0]], [[0.0, 0.0, 0.0]], [0.01], [0])
    for _ in range(120):
        s.step(DT)
        p = rot.T @ s.state()["x"][0]
        assert not np.all(np.abs(p) < np.array([0.5, 0.1, 0.5]) + 0.01 - 1e-3)
    assert s.state()["v"][0][0] < -0.1  # frictionless slope: it slides towards -x


def test_growing_the_store_keeps_every_particle(store_factory):
    s = store_factory([plane(y=-100.0)], capacity=1)
    assert s.capacity == MIN_CAPACITY
    n = MIN_CAPACITY + 37
    x = np.column_stack([np.arange(n), np.ones(n), np.zeros(n)]).astype(float)
    s.add(x[:10], np.zeros((10, 3)), np.full(10, 0.01), np.arange(10))
    s.add(x[10:], np.zeros((n - 10, 3)), np.full(n - 10, 0.01), np.arange(10, n))
    st = s.state()
    assert s.capacity >= n and s.count == n
    assert np.array_equal(st["particle"], np.arange(n)) and np.allclose(st["x"], x)


def box(e: float = 0.3, mu: float = 0.4) -> dict:
    rot = np.array([[math.cos(0.3), -math.sin(0.3), 0.0], [math.sin(0.3), math.cos(0.3), 0.0], [0.0, 0.0, 1.0]])
    return dict(type="box", x=[0.0, -0.05, 0.0], half=[0.5, 0.05, 0.5], rot=rot, restitution=e, friction=mu)


def test_the_host_copies_by_views_give_the_kernels_bits(store_factory, monkeypatch):
    """On the CPU the store's copies (added debris, its state, velocities set, the colliders) are numpy on
    views of its fields (rigid/host_views.py); through the kernels (CUDA's way) every step's state is the
    same, bit for bit, across a growth of the store."""
    import rigid.debris

    def run() -> list:
        s = store_factory([plane(e=0.4, mu=0.3), box()], capacity=1)
        rng = np.random.default_rng(7)
        states = []
        for k in range(3):  # the third add outgrows MIN_CAPACITY: the store is copied into a bigger one
            n = 10 if k < 2 else MIN_CAPACITY
            s.add(rng.uniform(-0.3, 0.3, (n, 3)) + [0.0, 0.5, 0.0], rng.normal(0.0, 1.0, (n, 3)),
                  rng.uniform(0.005, 0.02, n), np.arange(s.count, s.count + n))
            for _ in range(40):
                s.step(DT)
            s.set_velocities(np.arange(0, s.count, 3), np.tile([0.5, 1.0, 0.0], (len(range(0, s.count, 3)), 1)))
            states.append(s.state())
        s.release()
        return states

    by_views = run()
    monkeypatch.setattr(rigid.debris._DebrisArrays, "views", lambda self: None)
    by_kernels = run()
    assert by_views[-1]["x"].shape[0] == 20 + MIN_CAPACITY
    for a, b in zip(by_views, by_kernels):
        for key in ("x", "v", "r", "particle"):
            assert a[key].dtype == b[key].dtype and np.array_equal(a[key], b[key]), key
