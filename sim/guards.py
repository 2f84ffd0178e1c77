"""Guards that turn a failing simulation into a clear error before anything bad is written.

`check_state(world)` runs after every frame: non-finite state raises `SimulationError` naming the
field, the body or particle and the frame (DESIGN.md promise 2: hard cases stay stable, and when
they do not, the user learns where and when).
"""

from __future__ import annotations

import numpy as np

from sim.errors import SandboxError


class SimulationError(SandboxError):
    """The state became non-finite or unphysical; names the field, the entity and the step."""


def check_state(world) -> None:
    if "rigid" in world.stages:
        st = world.rigid.body_state()
        for name in ("x", "q", "v", "w"):
            arr = getattr(st, name)
            bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1) & st.alive)
            if bad.size:
                raise SimulationError(
                    f"non-finite body_{name} of body {bad[0]} ({bad.size} bodies) at frame {world.frame}"
                )
    if "elastic" in world.stages:
        x = world.elastic.positions()
        bad = np.flatnonzero(~np.all(np.isfinite(x), axis=1))
        if bad.size:
            raise SimulationError(f"non-finite particle_x of particle {bad[0]} at frame {world.frame}")
