"""Frames before the first contact step the bodies alone (rigid/free_flight.py): the pile falls free for
its first frames, and its state after the landing is the one the full step gives, bit for bit
(tests/regression/test_compile_once.py: the full step's kernels then compile in the warm-up)."""

from __future__ import annotations

from scenes.loader import load_scene
from sim.guards import state_hash
from sim.world import World

FRAMES = 22
# the pile lifted and spread out so that nothing is within reach of anything at the start: the lowest
# box lands in frame 14, the others later
SPREAD = ["objects.boxes.position=[0.0, 0.3, 0.0]", "objects.boxes.spacing=[0.01, 0.1, -0.005]",
          "objects.balls.position=[0.3, 0.4, 0.05]", "objects.balls.spacing=[-0.02, 0.1, 0.01]"]


def _run(free: bool) -> tuple[str, int, list[int]]:
    w = World(load_scene("rigid_pile", SPREAD), warm_events=False)
    try:
        # the full step's kernels are compiled in this process already: their warm-up pieces are dropped
        # unrun, so that the frames are free as long as no contact can come, whatever the pieces' times
        w.warm_up.pieces.clear()
        w.rigid.free_flight.on = free
        contacts = []
        for _ in range(FRAMES):
            w.step_frame()
            contacts.append(w.rigid.n_contacts)
        return state_hash(w), w.rigid.free_flight.frames, contacts
    finally:
        w.release()


def test_free_frames_give_the_full_steps_state():
    full_hash, none, full_contacts = _run(free=False)
    free_hash, frames, contacts = _run(free=True)
    assert none == 0
    assert 2 <= frames < FRAMES
    assert contacts[:frames] == [0] * frames  # the full step found no contact in those frames either
    assert full_contacts[:frames] == [0] * frames
    assert contacts == full_contacts and contacts[-1] > 0
    assert free_hash == full_hash

