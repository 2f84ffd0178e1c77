"""Runtime guards (sim/guards.py): a non-finite value is caught in the step it appears, named by
field, entity and step, and the frames written before it stay readable."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenes.loader import load_scene
from sim.guards import SimulationError, check_state, install_step_guard, state_hash
from sim.world import World

INJECT_FRAME = 3
BALL = 1  # glass_r3: the steel ball; it breaks the pane in frame 0 and flies free from frame 2


def _inject_body_v(world, body: int) -> None:
    world.rigid._s.body_v[body] = [np.nan, 0.0, 0.0]


def test_nan_in_body_velocity_stops_the_run_and_keeps_earlier_frames(tmp_path, monkeypatch):
    """sim.run with the raster renderer: NaN written into body_v of one body between frames 2 and 3
    -> SimulationError naming body_v, the body and frame 3 (the start-of-frame check, before any step
    of frame 3); frames 0-2 are complete PNGs, frame 3 is never written, and stats.json records the
    3 finished frames."""
    from PIL import Image

    from sim.run import RunOptions, run

    original = World.step_frame

    def step_frame(self):
        if self.frame == INJECT_FRAME:
            _inject_body_v(self, BALL)
        return original(self)

    monkeypatch.setattr(World, "step_frame", step_frame)
    out = tmp_path / "run"
    with pytest.raises(SimulationError) as info:
        run(load_scene("glass_r3"), RunOptions(out=out, frames=6, renderer="raster", video="none", width=64,
                                               height=48, progress=False))
    err = info.value
    assert err.field == "body_v" and err.entity == "body" and err.index == BALL and err.frame == INJECT_FRAME
    assert f"body_v of body {BALL}" in str(err) and f"frame {INJECT_FRAME}" in str(err)
    assert err.step == 4 * INJECT_FRAME  # caught before frame 3's first step (4 substeps per frame)
    assert "start of the frame" in str(err)
    frames = sorted((out / "frames").glob("frame_*.png"))
    assert [p.name for p in frames] == [f"frame_{k:05d}.png" for k in range(INJECT_FRAME)]
    for p in frames:
        with Image.open(p) as im:
            im.load()  # a truncated file raises here
            assert im.size == (64, 48)
            assert np.asarray(im).std() > 0  # a drawn picture, not an empty buffer
    assert not list((out / "frames").glob(".*"))  # no temporary file left behind
    stats = json.loads((out / "stats.json").read_text())
    assert stats["frames"] == INJECT_FRAME


def test_step_guard_names_the_injected_field_and_the_exact_step():
    """With install_step_guard the value is caught before the next rigid step runs: only body_v is
    bad (no position has moved through it yet), and the message names that step and substep. The
    value is written after the start-of-frame check, as a stage inside the frame would."""
    w = World(load_scene("glass_r3"))
    try:
        install_step_guard(w)
        w.step_frame()
        w.step_frame()
        step = w.rigid.step_count
        original = w._scripted_cracks
        w.cfg.cracks = [None]  # makes step_frame call the hook below after its start-of-frame check

        def inject():
            w._scripted_cracks = original
            _inject_body_v(w, BALL)

        w._scripted_cracks = inject
        with pytest.raises(SimulationError) as info:
            w.step_frame()
        err = info.value
        assert err.fields == ("body_v",) and err.index == BALL and err.step == step and err.frame == 2
        assert f"before rigid step {step} (substep 0 of frame 2" in str(err)
        st = w.rigid.body_state()  # nothing advanced: the bad value never entered a position
        assert np.all(np.isfinite(st.x[st.alive]))
    finally:
        w.release()


def test_start_of_frame_check_names_values_changed_between_frames():
    w = World(load_scene("glass_r3"))
    try:
        w.step_frame()
        w.rigid._s.body_q[1] = [np.inf, 0.0, 0.0, 0.0]
        with pytest.raises(SimulationError) as info:
            check_state(w, when="start")
        assert info.value.fields == ("body_q",) and info.value.index == 1
        assert "changed between frames" in str(info.value)
    finally:
        w.release()


def test_non_unit_quaternion_is_named():
    w = World(load_scene("glass_r3"))
    try:
        w.rigid._s.body_q[1] = [2.0, 0.0, 0.0, 0.0]
        with pytest.raises(SimulationError, match=r"body_q of body 1 is not a unit quaternion \(\|q\| = 2"):
            check_state(w, when="start")
    finally:
        w.release()


def test_bad_particle_table_is_named():
    """The particle store is checked after every fracture event (surface_version changed)."""
    w = World(load_scene("tet_cut_22"))
    try:
        check_state(w)  # the fresh table is fine (read from the build's host copy)
        w.store.particle_volume[0] = -1e-9
        w.store.version += 1  # as every change of the store does (an event's put_body): the kernel checks it
        w.surface_version += 1
        with pytest.raises(SimulationError) as info:
            check_state(w)
        assert info.value.field == "particle_volume" and info.value.entity == "particle" and info.value.index == 0
        w.store.particle_volume[0] = 1e-9
        w.store.particle_kernel[0, 2, 2] = -1.0  # diag(+, +, -): not positive definite
        w.store.version += 1
        w.surface_version += 1
        with pytest.raises(SimulationError, match="kernel_G of particle 0"):
            check_state(w)
    finally:
        w.release()


def test_nan_in_elastic_particle_is_named():
    cfg = load_scene("wire", ["objects.wire.shape.length=0.12"])
    w = World(cfg)
    try:
        w.step_frame()
        v = w.elastic.velocities()
        v[7] = np.nan
        w.elastic.particle_v.from_numpy(v)
        with pytest.raises(SimulationError) as info:
            w.step_frame()
        err = info.value
        assert err.entity == "particle" and err.field == "particle_v" and err.frame == 1
        assert "particle_v of particle" in str(err)
        bad = np.flatnonzero(~np.all(np.isfinite(w.elastic.velocities()), axis=1))
        assert 7 in bad and err.index == bad[0]  # its neighbours may have turned non-finite in the same frame
    finally:
        w.release()


def test_state_hash_is_reproducible_and_sensitive():
    hashes = []
    for _ in range(2):
        w = World(load_scene("glass_r3"))
        try:
            for _ in range(3):
                w.step_frame()
            hashes.append(state_hash(w))
            st = w.rigid.body_state()
            w.rigid.set_body_state(BALL, v=st.v[BALL] + [0.0, 1e-12, 0.0])
            hashes.append(state_hash(w))
        finally:
            w.release()
    assert hashes[0] == hashes[2] and hashes[1] == hashes[3]
    assert hashes[0] != hashes[1]
