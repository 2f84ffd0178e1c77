"""The free-flight step (rigid.step_kernels.k_free_flight): where no contact can be made it gives the
full step's state bit for bit (gravity, damping, tumbling, the speed and spin clamps, sleep). The
contact bound it relies on is tested in test_first_contact.py."""

from __future__ import annotations

import numpy as np
import pytest

from rigid.bodies import add_box_body

DT = 1.0 / 240.0


def _state(world) -> dict:
    st = world.body_state(fresh=True)
    return dict(x=st.x, q=st.q, v=st.v, w=st.w, asleep=st.asleep)


def _scatter(world) -> None:
    """Bodies far apart in the air: a tumbler, a fast spinner held by the spin clamp, one above the
    speed clamp, a slow one that falls asleep (no gravity in that test), and a static one."""
    add_box_body(world, [0.15, 0.10, 0.05], 1000.0, x=(0.0, 5.0, 0.0), v=(0.3, 1.0, -0.2), w=(0.01, 5.0, 0.01))
    add_box_body(world, [0.05, 0.05, 0.20], 500.0, x=(3.0, 5.0, 0.0), w=(200.0, -40.0, 9.0))
    add_box_body(world, [0.02, 0.02, 0.02], 7800.0, x=(-3.0, 5.0, 0.0), v=(0.0, 0.0, 250.0))
    add_box_body(world, [0.10, 0.10, 0.10], 800.0, x=(0.0, 5.0, 3.0), v=(0.001, 0.0, 0.0), w=(0.0, 0.001, 0.0))
    add_box_body(world, [0.10, 0.10, 0.10], 800.0, x=(0.0, 5.0, -3.0), static=True)


def _run(world, gravity, free: bool) -> list[dict]:
    world.clear()
    world.config.gravity = gravity
    world.config.linear_damping_per_s = 0.05
    world.config.angular_damping_per_s = 0.1
    _scatter(world)
    states = []
    for _ in range(150):  # past time_to_sleep: the slow body sleeps in zero gravity
        world.step(DT, free=free)
        assert world.n_contacts == 0 and world.fastest_closing() == 0.0
        states.append(_state(world))
    return states


@pytest.mark.parametrize("gravity", [(0.0, -9.81, 0.0), (0.0, 0.0, 0.0)])
def test_free_flight_step_is_the_full_step_without_contacts(fresh, gravity):
    full = _run(fresh, gravity, free=False)
    free = _run(fresh, gravity, free=True)
    for k, (a, b) in enumerate(zip(full, free)):
        for key in a:
            np.testing.assert_array_equal(b[key], a[key], err_msg=f"{key} after step {k + 1}")
    asleep = full[-1]["asleep"]
    assert asleep[3] == (gravity[1] == 0.0)  # both ways of the sleep rule are covered
    assert not asleep[:3].any()
    assert np.linalg.norm(full[0]["v"][2]) <= fresh.config.max_speed_mps  # the clamp ran (250 m/s at the start)

