"""Time steps above the stable ones are refused before anything is written (sim.guards.check_time_step,
check_scene); without the guard the NaN check stops the run at the end of the first bad frame."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from scenes.loader import load_scene
from sim.guards import SimulationError, TimeStepError, check_scene, check_time_step, stable_elastic_dt
from sim.world import World
from sph.elastic import ElasticEffect, stable_time_step
from sph.kernel import kernel_isotropic
from sph.materials import Material, stiffness_isotropic

WIRE = ["objects.wire.shape.length=0.12"]  # a short wire: 280 particles


@pytest.fixture(scope="module")
def wire():
    w = World(load_scene("wire", WIRE))
    yield w
    w.release()


def test_world_elastic_step_is_at_most_stable(wire):
    stable = check_time_step(wire)["elastic"]
    e = wire.elastic
    assert stable == pytest.approx(min(e.dt_rule, 0.7 * 2.0 / e.omega_max), rel=1e-12)
    assert e.dt <= stable * (1 + 1e-12)
    # the World splits a frame into equal steps no longer than the stable one
    assert e.dt * wire.elastic_steps_per_frame == pytest.approx(wire.dt_frame, rel=1e-12)
    assert e.dt > stable * wire.elastic_steps_per_frame / (wire.elastic_steps_per_frame + 1)


def test_elastic_step_above_stable_is_refused_before_any_frame(tmp_path):
    """dt = 1.5 x stable: check_time_step refuses it (the hook in World would stop the run before frame
    0); without the hook the run blows up within frame 0 and check_state stops it before the frame is
    written (frames = 0 either way)."""
    from render.writers import PngSequenceWriter

    w = World(load_scene("wire", WIRE))
    try:
        stable = stable_elastic_dt(w.elastic)
        w.elastic.dt = 1.5 * stable
        with pytest.raises(TimeStepError) as info:
            check_time_step(w)
        msg = str(info.value)
        assert info.value.key_path == "elastic.dt" and "1.5 x stable" in msg and f"{stable:.6g}" in msg
        # what the run loop does with the guard in front of the first frame: nothing is written
        frames = PngSequenceWriter(tmp_path / "frames")
        with pytest.raises(TimeStepError):
            for _ in range(3):
                check_time_step(w)
                w.step_frame()
                frames.write(np.zeros((8, 8, 3), np.uint8))
        frames.close()
        assert w.frame == 0 and not list((tmp_path / "frames").glob("*.png"))
        # and without the guard: the first frame goes non-finite and check_state names it
        e0 = w.elastic.energies()["total"]
        assert np.isfinite(e0)
        with pytest.raises(SimulationError) as info:
            w.step_frame()
        assert info.value.frame == 0 and info.value.entity == "particle"
    finally:
        w.release()


def test_effect_time_step_argument_is_checked():
    """An ElasticEffect given an explicit dt (so it measured no operator frequency): the guard measures
    it, accepts its stable step and refuses twice the CFL rule."""
    d = 0.02
    g = np.arange(5) * d
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    x = x + np.random.default_rng(1).uniform(-0.2, 0.2, x.shape) * d
    mat = Material("rubber", 1100.0, stiffness_isotropic(5e6, 0.45))
    G = kernel_isotropic(2.5 * d)
    rule = stable_time_step(np.broadcast_to(G, (len(x), 3, 3)), [mat], 0.15)
    eff = ElasticEffect(x, np.full(len(x), d**3), G, mat, dt=2.0 * rule, gravity=(0, 0, 0))
    try:
        assert eff.omega_max is None
        with pytest.raises(TimeStepError, match="elastic.dt"):
            check_time_step(eff)
        stable = stable_elastic_dt(eff)
        assert 0.0 < stable <= rule
        assert check_time_step(eff, dt=stable)["elastic"] == pytest.approx(stable, rel=1e-12)
    finally:
        eff.release()


def test_rigid_step_above_limit():
    """fps = 1, substeps = 1: a 1 s rigid step. The World refuses the scene with the key to change
    (check_scene); a World built around the check still refuses to step (ConfigError('rigid.dt'))."""
    cfg = load_scene("rigid_pile", ["scene.fps=1", "scene.substeps=1"])
    with pytest.raises(TimeStepError) as info:
        World(cfg)
    assert info.value.key_path == "scene.substeps" and ">= 10 at fps 1" in str(info.value)
    import sim.world as world_module

    original = world_module.check_scene
    world_module.check_scene = lambda cfg: None
    try:
        w = World(cfg)
    except TimeStepError:  # check_time_step at the end of the build refuses it as well
        w = None
    finally:
        world_module.check_scene = original
    if w is None:
        return
    try:
        with pytest.raises(TimeStepError):
            check_time_step(w)
        x0 = w.rigid.body_state().x.copy()
        with pytest.raises(ConfigError, match=r"rigid.dt = 1\.0 is invalid; allowed: \(0, 0.1\] s"):
            w.step_frame()
        assert np.array_equal(w.rigid.body_state().x, x0)
    finally:
        w.release()
    check_scene(load_scene("rigid_pile", ["scene.fps=10", "scene.substeps=1"]))  # exactly 0.1 s: accepted


def test_initial_speed_above_the_solver_clamp_is_refused():
    cfg = load_scene("glass_r3", ["objects.ball.velocity=[0,0,-500]"])  # the schema allows up to 1e3 m/s
    with pytest.raises(ConfigError) as info:
        check_scene(cfg)
    assert info.value.key_path == "objects[1].velocity" and "<= 200 m/s" in str(info.value)
    check_scene(load_scene("glass_r3", ["objects.ball.velocity=[0,0,-200]"]))
