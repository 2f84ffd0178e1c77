"""The host's copy of the bodies' state (RigidWorld.body_state): downloaded once until something writes
a body, so a frame's many readers cost one download; every writer makes the next read fresh, and a
reader's copy is its own."""

from __future__ import annotations

import numpy as np

from rigid.bodies import add_box_body

G = 9.81
DT = 1.0 / 240.0


def _downloads(w, monkeypatch) -> list:
    """The downloads of the bodies' state from the store (by its views on the CPU, else its kernel)."""
    calls = []
    inner = w._download_bodies

    def counted(n):
        calls.append(n)
        return inner(n)

    monkeypatch.setattr(w, "_download_bodies", counted)
    return calls


def _same_as_the_store(w) -> None:
    """What body_state returns is what a download of the store gives now, field by field."""
    st, raw = w.body_state(), w._download_bodies(w.n_bodies)
    for name in ("x", "q", "v", "w", "asleep", "alive", "sleep_time"):
        np.testing.assert_array_equal(getattr(st, name), getattr(raw, name), err_msg=name)


def test_readers_share_one_download_until_a_step(fresh, monkeypatch):
    w = fresh
    a = add_box_body(w, [0.1, 0.1, 0.1], 1000.0, x=(0.0, 2.0, 0.0))
    calls = _downloads(w, monkeypatch)
    first = w.body_state()
    for _ in range(5):
        w.body_state()
    w.awake_bodies()
    w.kinetic_energy()
    assert len(calls) == 1
    first.x[a] += 1.0  # a reader's copy is its own: the next reader does not see this
    assert w.body_state().x[a, 1] == 2.0
    w.step(DT)
    st = w.body_state()
    assert len(calls) == 2
    # symplectic Euler over the step's substeps, from rest: v = -g dt (the step moved the body)
    assert abs(st.v[a, 1] + G * DT) <= 1e-12 * G
    assert st.x[a, 1] < 2.0


def test_every_writer_makes_the_next_read_fresh(fresh):
    w = fresh
    a = add_box_body(w, [0.1, 0.1, 0.1], 1000.0, x=(0.0, 2.0, 0.0))
    _same_as_the_store(w)
    b = add_box_body(w, [0.1, 0.1, 0.1], 1000.0, x=(1.0, 2.0, 0.0))  # an upload
    assert w.body_state().x[b, 0] == 1.0
    _same_as_the_store(w)
    w.set_body_state(a, v=(3.0, 0.0, 0.0))
    assert w.body_state().v[a, 0] == 3.0
    _same_as_the_store(w)
    w.step(DT)
    _same_as_the_store(w)
    w.config.time_to_sleep_s = 0.0  # asleep after one slow step, then woken
    w.config.gravity = (0.0, 0.0, 0.0)
    w.set_body_state(b, v=(0.0, 0.0, 0.0))
    w.step(DT)
    assert w.body_state().asleep[b]
    w.wake([b])
    assert not w.body_state().asleep[b]
    _same_as_the_store(w)
    w.remove_bodies([a])
    st = w.body_state()
    assert not st.alive[a] and st.alive[b]
    _same_as_the_store(w)
    cap = w.capacity["bodies"]
    for k in range(cap):  # past the capacity: the store is rebuilt bigger, the state copied over
        add_box_body(w, [0.05, 0.05, 0.05], 1000.0, x=(0.0, 5.0 + 0.2 * k, 0.0))
    assert w.grow_count >= 1
    assert w.body_state().alive.sum() == cap + 1
    _same_as_the_store(w)
