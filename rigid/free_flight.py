"""When a frame's rigid steps may move the bodies alone (issue 16: a start that does not compile what
only a contact needs; DESIGN.md: only what a scene calls for runs).

Before its first contact a dropped or launched body only falls: the broad and narrow phases find
nothing and the solver has no contact to solve, yet the full step runs them all, and their kernels
(1.9 s of frontend and JIT at a warm start, docs/decisions.md) compile at the first frame. Until
they have compiled (as warm-up pieces in the frames of the fall, sim/warm_up.py `free_frame`), a
frame in which no contact can be made runs `rigid.step(..., free=True)` instead: the free-flight
kernels of rigid/step_kernels.py, which give the full step's state bit for bit
(tests/unit/test_rigid_free_flight.py). Where the warm-up runs before the first frame (a contact is
near, or no drawing process leaves idle time) the full step runs from the start.

A frame is free when `rigid.first_contact` bounds the first contact at least one rigid step beyond
the frame's end (a speculative contact is made at the start of the step in which a pair can close),
and no moving body can reach the speed clamp in it (the clamp would stop one of two bodies falling
together, and the bound takes their gap as closing only at their relative speed). The first frame
that is not free ends the free frames for good: afterwards bodies touch, split and scatter, and the
bound would cost more than it saves.
"""

from __future__ import annotations

import numpy as np


class FreeFlight:
    """The free frames of one rigid world (module doc)."""

    def __init__(self, world) -> None:
        self.world = world  # rigid.world.RigidWorld
        self.on = True  # False once a frame was not free
        self.frames = 0  # free frames so far

    def frame_is_free(self, frame_s: float, step_s: float) -> bool:
        """True if no contact can be made in the next `frame_s` seconds, stepped in steps of `step_s`."""
        if not self.on:
            return False
        from rigid.first_contact import earliest_contact_s

        w = self.world
        cfg = w.config
        g = float(np.linalg.norm(np.asarray(cfg.gravity, dtype=np.float64)))
        st = w.body_state()
        moving = st.alive & ~st.asleep & ~w.static_mask()
        fastest = float(np.linalg.norm(st.v[moving], axis=1).max(initial=0.0))
        free = (fastest + g * frame_s < cfg.max_speed_mps
                and earliest_contact_s(w, cfg.gravity, cfg.speculative_margin_m) >= frame_s + step_s)
        self.on = free
        self.frames += int(free)
        return free


__all__ = ["FreeFlight"]
