"""sim/warm_up.py: the event kernels' warm-up pieces spread over the frames before the first contact
by time (`WarmUp.run_share`): each frame takes its share of what is left, at least one piece,
and all have run by the last frame before a contact could come. Pieces here advance a clock of
their own (no real time is measured)."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from sim.warm_up import PIECE_FLOOR_S, WarmUp


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _warm_up(durations) -> tuple[WarmUp, _Clock, list]:
    clock, ran = _Clock(), []

    def piece(k: int, d: float):
        def run() -> None:
            clock.now += d
            ran.append(k)
        return run

    w = WarmUp.__new__(WarmUp)  # no World: only the spreading is under test
    w.pieces = deque(piece(k, d) for k, d in enumerate(durations))
    w.clock, w.spent, w.ran, w.idle = clock, 0.0, 0, True
    return w, clock, ran


def test_pieces_are_spread_by_time_and_all_run_before_the_contact():
    rng = np.random.default_rng(5)
    durations = rng.choice([0.005, 0.015, 0.03, 0.06, 0.09], size=40)  # s: imports and first launches
    frames = 17
    w, clock, ran = _warm_up(durations)
    work = []
    for left in range(frames, 0, -1):  # frames before a contact could come, this one included
        t0 = clock.now
        if left == 1:
            w.run_all()  # WarmUp.before_frame: the last frame runs what is left
        else:
            share = max(w.spent / w.ran if w.ran else 0.0, PIECE_FLOOR_S) * len(w.pieces) / left
            n0 = len(w.pieces)
            w.run_share(left)
            assert len(w.pieces) < n0  # at least one a frame
            assert clock.now - t0 <= share + durations.max() + 1e-12  # never more than the share and one piece
        work.append(clock.now - t0)
    assert ran == list(range(len(durations)))  # all, in order
    assert sum(work) == pytest.approx(durations.sum(), rel=1e-12)
    # the even spread: no frame holds much more than its part of the whole (the count rule, three
    # pieces a frame, gave frames of up to three of the heaviest pieces)
    assert max(work) <= 2.0 * durations.sum() / frames + durations.max()


def test_a_share_runs_no_piece_past_it_but_always_one():
    w, clock, ran = _warm_up([0.05] * 10)
    w.run_share(5)  # none run yet: PIECE_FLOOR_S a piece, a 60 ms share
    assert ran == [0]
    w.run_share(5)  # 9 pieces of 50 ms in 5 frames: a 90 ms share, which a second piece would pass
    assert ran == [0, 1]
    w.run_share(20)  # a share smaller than one piece: still one
    assert ran == [0, 1, 2]
