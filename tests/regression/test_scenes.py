"""Every scene in scenes/ loads, builds and runs its test frames headless with sane invariants, and
the headless camera keeps every body in the image at the first frame and the last."""

from __future__ import annotations

import numpy as np
import pytest

import anisofrac as af
from render.camera import box_corners
from render.session import HeadlessSession
from scenes.loader import scene_names
from sim.world import World

SLOW = ("pots", "pet", "wire")  # the big scenes, and the elastic wire (about 20 s of stepping)
FAST = [n for n in scene_names() if n not in SLOW]


W, H = 640, 480  # px: the default frame size of `main.py run`


def _bodies_in_view(session: HeadlessSession) -> bool:
    """Every corner of the bodies' world bounds projects inside the frame of the following camera."""
    session.draw()
    px, _, _ = session.camera.project(box_corners(*session.view.scene.body_bounds()), W, H)
    return bool(np.all((px >= 0.0) & (px <= [W, H])))


def run_scene(name: str) -> af.Simulation:
    """Run the scene's test frames through the Python API, following it with the headless camera
    (checked at both ends)."""
    sim = af.load(name)
    cfg, world = sim.config, sim.world
    session = HeadlessSession(world, "none", W, H) if "rigid" in world.stages else None
    frames = cfg.scene.test_frames or cfg.scene.frames
    try:
        for f in range(frames):
            if session is not None:
                in_view = _bodies_in_view(session)
                assert in_view or f not in (0, frames - 1) or cfg.camera.mode == "fixed", (name, f)
            sim.step()
    finally:
        if session is not None:
            session.close()
    return sim


def check_readouts(sim: af.Simulation) -> None:
    """What the API reads agrees with the World: particle masses add up to the live mass, every link
    joins two live particles once, bodies' masses are the rigid world's, the stats hold Table 1."""
    world = sim.world
    parts = sim.particles()
    assert parts.mass.sum() == pytest.approx(world.mass_balance()["alive_kg"], rel=1e-12)
    assert np.all(np.isfinite(parts.x[parts.body >= 0]))
    links = sim.links()
    assert np.all(links[:, 0] < links[:, 1]) and len(np.unique(links, axis=0)) == len(links)
    assert np.all(world.particles.alive[links])
    assert sim.stats()["table1"] == world.counts()
    for b in sim.bodies():
        assert b.mass == world.rigid.body_mass(b.id) and b.particles >= 1


def check_world(world: World) -> None:
    ps = world.particles
    # mass: exactly conserved across fragments (alive particles + debris taken out)
    bal = world.mass_balance()
    assert abs(bal["error_kg"]) <= 1e-12 * bal["initial_kg"]
    # every alive particle belongs to a live body, and body masses add up to the alive mass
    if "rigid" in world.stages:
        st = world.rigid.body_state()
        for name in ("x", "q", "v", "w"):
            assert np.all(np.isfinite(getattr(st, name)[st.alive]))
        in_body = ps.alive & (ps.body >= 0)  # body -1: debris, moved by the debris store
        bodies = np.unique(ps.body[in_body])
        assert np.all(st.alive[bodies])
        masses = sum(world.rigid.body_mass(int(b)) for b in bodies if not world.rigid.body_is_static(int(b)))
        dynamic = np.array([not world.rigid.body_is_static(int(b)) for b in ps.body[in_body]], dtype=bool)
        assert masses == pytest.approx(ps.mass[in_body][dynamic].sum(), rel=1e-12)
        # the store was sized at build for what fracture adds: it never grew (a growth recompiles every
        # rigid kernel: a pause of seconds in the middle of a run)
        assert world.rigid.grow_count == 0, world.rigid.capacity
        freed = np.flatnonzero(ps.alive & (ps.body < 0))
        if "debris" in world.stages:
            assert np.array_equal(np.sort(world.debris.state()["particle"]), freed)
        else:
            assert freed.size == 0
    if "elastic" in world.stages:
        assert np.all(np.isfinite(world.elastic.positions()))
    lo, hi = world.cfg.scene.expected_fragments
    assert lo <= world.fragment_count() <= hi, (world.cfg.scene.name, world.fragment_count())


@pytest.mark.parametrize("name", FAST)
def test_scene_runs_its_test_frames(name):
    sim = run_scene(name)
    try:
        check_world(sim.world)
        check_readouts(sim)
    finally:
        sim.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_large_scene_runs_its_test_frames(name):
    sim = run_scene(name)
    try:
        check_world(sim.world)
        if name == "pots":
            assert 75_000 <= sim.world.counts()["physical_particles"] <= 90_000
    finally:
        sim.close()
