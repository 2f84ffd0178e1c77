"""Stacks of boxes made of tets with 8 corner boundary spheres stand for 5 s (DESIGN.md 5: stable
stacking of fragment piles), also with a box 100 times denser on top."""

from __future__ import annotations

import numpy as np
import pytest

from rigid.bodies import add_box_body
from rigid.world import RigidConfig

DT = 1.0 / 240.0
HALF = 0.1  # m: box half extent
R_SPHERE = 0.02  # m: corner sphere radius


def _stack(w, n, heavy_top, sleep):
    w.clear()
    w.config = RigidConfig(sleep_enabled=sleep)
    w.add_plane((0, 0, 0), (0, 1, 0), friction=0.5)
    ids = []
    for k in range(n):
        rho = 100_000.0 if (heavy_top and k == n - 1) else 1000.0
        ids.append(
            add_box_body(w, [HALF] * 3, rho, x=(0.0, HALF + 2 * HALF * k, 0.0), sphere_radius=R_SPHERE)
        )
    x0 = w.body_state().x[ids[-1]].copy()
    drift = vmax_top = pen = 0.0
    for _ in range(int(5.0 / DT)):
        w.step(DT)
        st = w.body_state()
        drift = max(drift, float(np.linalg.norm(st.x[ids[-1]] - x0)))
        vmax_top = max(vmax_top, float(np.linalg.norm(st.v[ids[-1]])))
        ev = w.contact_events()
        if len(ev):
            pen = max(pen, float(-ev.separation.min()))
    speed_end = float(np.linalg.norm(st.v[ids], axis=1).max())
    print(
        f"stack n={n} heavy={heavy_top} sleep={sleep}: top drift {drift * 1e3:.3f} mm, top max speed "
        f"{vmax_top:.4f} m/s, final max speed {speed_end:.2e} m/s, max penetration {pen * 1e3:.4f} mm"
    )
    return drift, speed_end, pen, st.asleep[ids]


@pytest.mark.parametrize("n,heavy", [(5, False), (10, False), (5, True), (10, True)])
def test_stack_stands_for_five_seconds_without_sleeping(world, n, heavy):
    drift, speed_end, pen, _asleep = _stack(world, n, heavy, sleep=False)
    assert world.awake_bodies() == n
    assert drift < 1e-3
    assert speed_end < 0.01
    assert pen < 0.5 * R_SPHERE


def test_heavy_ten_stack_settles_and_sleeps(world):
    drift, speed_end, pen, asleep = _stack(world, 10, True, sleep=True)
    assert drift < 1e-3
    assert speed_end < 0.01
    assert pen < 0.5 * R_SPHERE
    assert asleep.all()
    assert world.awake_bodies() == 0
    world.wake([3])
    assert world.awake_bodies() == 1
    add_box_body(world, [HALF] * 3, 1000.0, x=(1.0, HALF, 0.0), sphere_radius=R_SPHERE, static=True)
    assert world.awake_bodies() == 1  # a static body is never counted
