"""When the kernels that only contacts and fracture events launch are compiled (issue 16: start-up,
and the first event as fast as the tenth).

Taichi compiles a kernel at its first launch, even from its offline cache (10-25 ms for a small one,
over 100 ms for the store's gather: docs/decisions.md, session 27). Two sets wait for a contact: the
full rigid step's (rigid.step.warm_pieces: 1.9 s of frontend and JIT at a warm start; until the first
contact can come, frames step the bodies alone, rigid/free_flight.py), and those that only events and
debris launch (sim.fracture_stage.warm_pieces), with the libraries an event imports (0.9-1.2 s,
glass_r3, docs/decisions.md session 32). A World built with warm_events=True runs them all at the
end of its build. One built with warm_events=False (`main.py run`) with a drawing process runs
START_WARM_S of them before the first frame, the rigid step's first (its frontends and first launches
are the heaviest pieces, 20-120 ms each), and the rest in the time the simulation waits for the
drawing process (`run_one` is its idle work: the pot's falling frames take 8 ms to step and 40 ms to
draw), provided the first contact cannot come before SAFETY_FRAMES + 1 frames (rigid.first_contact
gives a lower bound on its time; a ball launched at a pane: all before the first frame, as at the
build). Time spent before the first frame counts as the build's (stats.json `build_s`). Those the idle
time has not run by the time the frames left before a contact are fewer than them run in those
frames, spread by time: each frame takes its share of what is left (the pieces left of each kind, the
rigid step's and the events', times that kind's mean time so far, at least PIECE_FLOOR_S, over the
frames left), so that no frame of the fall stalls on several heavy pieces at once (the pot's frames
6-7 took 200 ms with three pieces each under a rule of so many pieces a frame; with one mean for both
kinds the rigid step's pieces, 90-330 ms, priced the events' 5-110 ms ones and the pot's first fall
frames ran two or three heavy pieces each: 300-570 ms, now 235-378 ms, session 38). Without idle
time they all run before the first frame.
The budget before the first frame (session 42): with none, the first frame came about 1.3 s after
the launch and the pot's and the Tai Chi disc's falling frames took 70-190 ms, each with a heavy piece
or its share of 1.5 s of pieces, and the drawing process sat idle at the start; with 1 s of pieces
there (the start, 2.0 s on sessions 41-42's machine, stayed under issue 16's 3 s; 3.1 s on session
43's slower one, where the pieces' 3.0-3.4 s leave 100-220 ms a falling frame), those frames took 30-80
ms and the whole run is no longer (the pieces overlap the drawing process's own start).
A fracture event runs any that are left first.
"""

from __future__ import annotations

import math
import time
from collections import deque

SAFETY_FRAMES = 2  # frames kept between the last piece and the earliest possible contact
# s: the least a piece is taken to last when a frame's share is reckoned, and the time of each piece of
# a kind none of which has run yet: the first event pieces are imports numpy has made already (0-8 ms),
# and a mean of those alone leaves the heavy ones (scipy's packages, 40-110 ms; first launches, 10-60
# ms) piled up for the last frames
PIECE_FLOOR_S = 0.03
START_WARM_S = 1.0  # s: the pieces run before the first frame where idle time could take them (module doc)


def warm_pieces(world) -> tuple[list, int]:
    """The pieces of a World: the full rigid step's kernels (how many: the second value), then those of
    fracture events."""
    pieces = []
    if "rigid" in world.stages:
        from rigid.step import warm_pieces as step_pieces

        pieces += step_pieces(world.rigid)
    steps = len(pieces)
    if world.mode is not None:
        from sim.fracture_stage import warm_pieces as event_pieces

        pieces += event_pieces(world)
    return pieces, steps


class WarmUp:
    """The warm-up pieces of one World, and when to run them (module doc)."""

    def __init__(self, world) -> None:
        self.world = world
        pieces, self.step_pieces = warm_pieces(world)
        self.pieces = deque(pieces)
        self.idle = False  # True where a drawing process gives the simulation idle time (run_one)
        self.clock = time.perf_counter  # s: what the pieces' times are read from
        self.spent = [0.0, 0.0]  # s: the pieces run so far, the rigid step's and the events'
        self.ran = 0  # how many pieces have run

    def run_one(self) -> bool:
        """Run the next piece; False when none was left."""
        if not self.pieces:
            return False
        t0 = self.clock()
        self.pieces.popleft()()
        self.spent[self.ran >= self.step_pieces] += self.clock() - t0
        self.ran += 1
        return True

    def _means(self) -> tuple[float, float]:
        """s: a rigid-step piece's and an event piece's time as the pieces run so far tell it (at least
        PIECE_FLOOR_S; a kind none of which has run yet counts PIECE_FLOOR_S)."""
        ran_step = min(self.ran, self.step_pieces)
        ran_event = self.ran - ran_step
        return (max(self.spent[0] / ran_step if ran_step else 0.0, PIECE_FLOOR_S),
                max(self.spent[1] / ran_event if ran_event else 0.0, PIECE_FLOOR_S))

    def _next_mean(self, means: tuple[float, float]) -> float:
        """s: the time `_means` expects of the next piece, by its kind."""
        return means[self.ran >= self.step_pieces]

    def run_all(self) -> None:
        while self.run_one():
            pass

    def before_frame(self) -> None:
        """At the start of a frame: all that are left, unless idle time runs them and a contact cannot
        come before SAFETY_FRAMES + 1 frames; then START_WARM_S of them at the first frame, and later,
        once the frames left are fewer than the pieces, this frame's share (`run_share`): the last
        frame before a contact could come runs all that are left."""
        if not self.pieces:
            return
        w = self.world
        frames = self.frames_to_first_contact() - SAFETY_FRAMES  # this one included
        t0 = time.perf_counter()
        if frames <= 1 or not self.idle:  # a contact could come at once, or no idle time to use: all now
            self.run_all()
        elif w.frame == 0:
            if START_WARM_S > 0.0:
                self.run_for(START_WARM_S)
        elif frames <= len(self.pieces):  # the idle time did not do them all: the rest in the frames left
            self.run_share(frames)
        if w.frame == 0:  # before the first frame: part of the build, as where the World ran them
            w.build_seconds += time.perf_counter() - t0

    def free_frame(self, step_s: float) -> bool:
        """Whether this frame steps the bodies alone (rigid/free_flight.py): while the full step's
        kernels have not compiled, and no contact can be made in it. Once they have (before the first
        frame, where a contact is near or no drawing process leaves idle time), the full step runs: it
        gives the same state, and the free step's own kernels would only add to the start."""
        w = self.world
        return self.ran < self.step_pieces and w.rigid.free_flight.frame_is_free(w.dt_frame, step_s)

    def run_share(self, frames: int) -> None:
        """This frame's share of the pieces left, `frames` frames (this one included) before they
        must all have run (`run_for`, priced by the means before it)."""
        means = self._means()
        step_left = max(self.step_pieces - self.ran, 0)
        left = means[0] * step_left + means[1] * (len(self.pieces) - step_left)  # s: what is left, estimated
        self.run_for(left / frames, means)

    def run_for(self, budget: float, means: tuple[float, float] | None = None) -> None:
        """Pieces in order, at least one, then more while the next one's expected time (`means`, else
        the means of the pieces run so far) still fits in `budget` (s) with those run here."""
        t0 = self.clock()
        self.run_one()
        while self.pieces and self.clock() - t0 + self._next_mean(means or self._means()) <= budget:
            self.run_one()

    def frames_to_first_contact(self) -> float:
        """Whole frames from now before a contact could be made (a scripted crack counts as one)."""
        from rigid.first_contact import earliest_contact_s

        w = self.world
        cracks = [c.frame - w.frame for c in w.cfg.cracks if c.frame >= w.frame]
        frames = float(min(cracks)) if cracks else math.inf
        if "rigid" in w.stages:
            cfg = w.rigid.config
            t = earliest_contact_s(w.rigid, cfg.gravity, cfg.speculative_margin_m)
            frames = min(frames, math.floor(t / w.dt_frame) if math.isfinite(t) else math.inf)
        return frames


__all__ = ["SAFETY_FRAMES", "START_WARM_S", "WarmUp", "warm_pieces"]
