"""A frame is the list of stages its scene's effects build (sim/stages.py): the paper scenes' lists,
the fixed order, every stage timed under its own name, and per effect: a disabled effect's stage is
not built, its code never runs (spied) and it allocates nothing."""

from __future__ import annotations

import pytest

import geometry.fragments
import sph.kernel
from scenes.loader import load_scene, scene_from_dict
from sim.stages import CATALOGUE, ORDER, build_stages, stage_list
from sim.world import World

PAPER = {
    "pot": ["rigid", "debris", "fracture.events", "fracture.analysis", "fracture.subdivision", "fracture.shatter",
            "fracture.split"],
    "pot_basic": ["rigid", "debris", "fracture.events", "fracture.analysis", "fracture.links", "fracture.shatter",
                  "fracture.split"],
    "glass_r3": ["rigid", "debris", "fracture.events", "fracture.analysis", "fracture.subdivision",
                 "fracture.shatter", "fracture.split"],
    "rigid_pile": ["rigid"],
    "tet_cut_31": ["rigid", "fracture.events", "fracture.analysis", "fracture.subdivision", "fracture.split"],
    "wire": ["elastic"],
}
for _name in ("glass_r5", "pots", "pet", "taichi"):
    PAPER[_name] = PAPER["glass_r3"]


def block(effects: list[str], mode: str = "auto", kernel: dict | None = None) -> dict:
    """A 6 x 2 x 6 cm block cut at frame 0 by a scripted crack with a 1.5 cm shatter radius."""
    return dict(
        scene=dict(name="block", effects=effects, fracture_mode=mode, gravity=[0.0, 0.0, 0.0]),
        materials=[dict(name="glass", density=2500.0, stiffness=dict(model="isotropic", E=7.0e10, nu=0.22),
                        kernel=kernel or dict(mode="isotropic", support=2.0))],
        objects=[dict(name="block", shape=dict(type="box", size=[0.06, 0.02, 0.06]), material="glass",
                      resolution=0.012, position=[0.0, 0.2, 0.0])],
        cracks=[dict(frame=0, object="block", point=[0.003, 0.2, 0.002], normal=[1.0, 0.0, 0.2], radius=0.1,
                     r_inner=0.015)],
    )


@pytest.mark.parametrize("name", sorted(PAPER))
def test_paper_scene_stage_lists(name):
    assert stage_list(load_scene(name)) == PAPER[name]


def test_the_order_is_fixed_and_asserted():
    assert ORDER == [s.name for s in CATALOGUE] and len(set(ORDER)) == len(ORDER)
    every = ["rigid", "fracture", "subdivision", "shatter", "debris", "elastic", "wpca"]
    assert [s.name for s in build_stages(every, "subdivision")] == [n for n in ORDER if n != "fracture.links"]


def _run_block(raw: dict, monkeypatch, spies: dict[str, tuple]) -> tuple[World, dict[str, int]]:
    calls = {k: 0 for k in spies}
    for key, (owner, attr) in spies.items():
        real = getattr(owner, attr)

        def spy(*a, _real=real, _key=key, **kw):
            calls[_key] += 1
            return _real(*a, **kw)

        monkeypatch.setattr(owner, attr, spy)
    w = World(scene_from_dict(raw, "block"))
    w.step_frame()
    return w, calls


SPIES = {"subdivide": (geometry.fragments, "subdivide"), "shatter": (geometry.fragments, "shatter_particles"),
         "wpca": (sph.kernel, "kernel_wpca")}


@pytest.mark.parametrize("effects, mode, ran, idle", [
    (["rigid", "fracture", "subdivision", "shatter", "debris"], "auto", {"subdivide", "shatter"}, {"wpca"}),
    (["rigid", "fracture", "subdivision"], "auto", {"subdivide"}, {"shatter", "wpca"}),
    (["rigid", "fracture", "subdivision", "shatter"], "basic", {"shatter"}, {"subdivide", "wpca"}),
    (["rigid", "fracture", "shatter"], "auto", {"shatter"}, {"subdivide", "wpca"}),
])
def test_a_disabled_effect_runs_nothing(taichi_runtime, monkeypatch, effects, mode, ran, idle):
    w, calls = _run_block(block(effects, mode), monkeypatch, SPIES)
    try:
        assert {k for k, n in calls.items() if n} == ran, calls
        timed = {k for k in w.timers.total if k in ORDER}
        # every built stage ran and was timed, no other (a scripted crack needs no analysis)
        assert timed == set(w.stages) - {"fracture.analysis"}, (timed, w.stages)
        assert len(w.events) == 1 and w.pieces()["total"] >= 2
        assert ("debris" in w.allocations) == ("debris" in effects) and "elastic" not in w.allocations
        assert ("fracture.shatter" in w.stages) == ("shatter" in effects)
    finally:
        w.release()


def test_wpca_runs_only_with_its_effect(taichi_runtime, monkeypatch):
    raw = block(["rigid", "fracture", "wpca"], kernel=dict(mode="wpca", support=2.0))
    w, calls = _run_block(raw, monkeypatch, SPIES)
    w.release()
    assert calls["wpca"] >= 1
