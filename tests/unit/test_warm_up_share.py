"""sim/warm_up.py: the event kernels' warm-up pieces spread over the frames before the first contact
by time (`WarmUp.run_share`): each frame takes its share of what is left, at least one piece,
and all have run by the last frame before a contact could come. Pieces here advance a clock of
their own (no real time is measured)."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from sim.warm_up import PIECE_FLOOR_S, START_WARM_S, WarmUp


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _warm_up(durations, step_pieces: int = 0) -> tuple[WarmUp, _Clock, list]:
    clock, ran = _Clock(), []

    def piece(k: int, d: float):
        def run() -> None:
            clock.now += d
            ran.append(k)
        return run

    w = WarmUp.__new__(WarmUp)  # no World: only the spreading is under test
    w.pieces = deque(piece(k, d) for k, d in enumerate(durations))
    w.clock, w.spent, w.ran, w.idle, w.step_pieces = clock, [0.0, 0.0], 0, True, step_pieces
    return w, clock, ran


def _spread(w: WarmUp, clock: _Clock, frames: int, bound=None) -> list[float]:
    """Each frame's work (s) over `frames` frames before a contact, the last running what is left;
    `bound(left)`, asked before a frame's share runs: the most that frame may take."""
    work = []
    for left in range(frames, 0, -1):  # frames before a contact could come, this one included
        t0 = clock.now
        if left == 1:
            w.run_all()  # WarmUp.before_frame: the last frame runs what is left
        else:
            most = bound(left) if bound is not None else None
            n0 = len(w.pieces)
            w.run_share(left)
            assert len(w.pieces) < n0  # at least one a frame
            assert most is None or clock.now - t0 <= most
        work.append(clock.now - t0)
    return work


def test_pieces_are_spread_by_time_and_all_run_before_the_contact():
    rng = np.random.default_rng(5)
    durations = rng.choice([0.005, 0.015, 0.03, 0.06, 0.09], size=40)  # s: imports and first launches
    frames = 17
    w, clock, ran = _warm_up(durations)

    def share_and_one_piece(left: int) -> float:  # never more than the share and one piece
        share = max(w.spent[1] / w.ran if w.ran else 0.0, PIECE_FLOOR_S) * len(w.pieces) / left
        return share + durations.max() + 1e-12

    work = _spread(w, clock, frames, share_and_one_piece)
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


def test_the_rigid_steps_heavy_pieces_do_not_price_the_events_light_ones():
    """The pot's warm-up: the rigid step's pieces (frontends and first launches, 90-330 ms) come first,
    then 40-odd event pieces of tens of ms. Each kind's pieces are priced by their own mean: a frame runs
    one heavy piece, not two or three (one mean for both ran 300-570 ms frames in the pot's fall), and
    all have run by the last frame."""
    durations = [0.16] * 6 + [0.04] * 40  # s
    frames = 17
    w, clock, ran = _warm_up(durations, step_pieces=6)
    work = _spread(w, clock, frames)
    assert ran == list(range(len(durations)))
    assert max(work[:6]) <= 0.16 + 0.04 + 1e-12  # a heavy piece, and at most one light one with it
    assert max(work) <= 2.0 * sum(durations) / frames + 0.16
    # the rule with one mean for both kinds, for comparison: two heavy pieces in a frame
    w1, clock1, _ = _warm_up(durations, step_pieces=0)
    assert max(_spread(w1, clock1, frames)[:3]) >= 2 * 0.16


class _World:
    """What WarmUp.before_frame reads of a World: the frame, and where the first frame's pieces count."""

    def __init__(self, frame: int) -> None:
        self.frame, self.build_seconds = frame, 0.0


@pytest.mark.parametrize("contact_in", [30.0, 2.0])
def test_the_first_frame_runs_the_start_budget_of_pieces_in_order_or_all_of_them(contact_in):
    """Frame 0 with idle time and a contact far off: pieces in order while the next one's expected time
    fits in START_WARM_S (the rigid step's, priced by their own mean, first), the rest left for the
    frames; with a contact as near as SAFETY_FRAMES + 1 frames, all of them."""
    durations = [0.12, 0.08, 0.1, 0.06] * 3 + [0.03] * 30  # s: 12 rigid-step pieces, then the events'
    w, clock, ran = _warm_up(durations, step_pieces=12)
    w.world = _World(0)
    w.frames_to_first_contact = lambda: contact_in
    w.before_frame()
    if contact_in <= 3.0:
        assert ran == list(range(len(durations)))
        return
    assert ran == list(range(len(ran))) and 0 < len(ran) < len(durations)
    # priced by their kind's mean so far: never past the budget by more than a piece, and never a
    # piece short of it
    assert START_WARM_S - max(durations) < clock.now <= START_WARM_S + max(durations)


def test_no_start_budget_runs_no_piece_at_the_first_frame(monkeypatch):
    import sim.warm_up

    monkeypatch.setattr(sim.warm_up, "START_WARM_S", 0.0)
    w, clock, ran = _warm_up([0.05] * 10)
    w.world = _World(0)
    w.frames_to_first_contact = lambda: 30.0
    w.before_frame()
    assert ran == [] and len(w.pieces) == 10  # every piece left for the frames (run_share)
