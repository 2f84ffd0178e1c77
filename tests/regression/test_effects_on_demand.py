"""Only what a scene calls for runs: a rigid-only scene builds, imports and launches nothing else."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from scenes.loader import load_scene
from sim.world import World

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import json, sys
sys.path.insert(0, {root!r})
from core.runtime import init_taichi
init_taichi("cpu", "f64", threads=1)
import taichi as ti
from scenes.loader import load_scene
from sim.world import World
w = World(load_scene("rigid_pile"))
for _ in range(3):
    w.step_frame()
print(json.dumps(dict(
    stages=w.stages,
    allocations=sorted(w.allocations),
    modules=sorted(m for m in sys.modules if m.split(".")[0] in ("sph", "geometry", "rigid", "render")),
)))
"""

FRACTURE_MODULES = {"sph.corotated", "sph.neighbours", "sph.elastic", "sph.cracks", "sph.contact", "sph.kernel",
                    "geometry.cutting", "geometry.subdivision", "geometry.fragments", "geometry.surface",
                    "sph.structure", "rigid.debris"}


def test_rigid_pile_builds_no_fracture_or_sph_stage():
    out = subprocess.run([sys.executable, "-c", PROBE.format(root=str(ROOT))], capture_output=True, text=True,
                         timeout=300, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-2000:]
    info = json.loads(out.stdout.strip().splitlines()[-1])
    assert info["stages"] == ["rigid"]
    assert info["allocations"] == ["rigid"]
    # a module never imported can neither allocate a field nor compile or launch a kernel
    loaded = set(info["modules"])
    assert not (loaded & FRACTURE_MODULES), loaded & FRACTURE_MODULES
    assert "rigid.world" in loaded


def test_world_allocations_match_stages():
    w = World(load_scene("tet_cut_31"))
    try:
        assert sorted(w.allocations) == ["rigid"]
        assert not hasattr(w, "elastic")
    finally:
        w.release()


def test_debris_store_only_with_the_debris_effect():
    """Shattered particles move only where the scene asks for 'debris'; without it nothing is allocated
    and they leave the simulation with their mass booked (mass_balance)."""
    cfg = load_scene("glass_r3", ["scene.effects=[\"rigid\",\"fracture\",\"subdivision\",\"shatter\"]"])
    w = World(cfg)
    try:
        assert "debris" not in w.stages and "debris" not in w.allocations and not hasattr(w, "debris")
    finally:
        w.release()
    w = World(load_scene("glass_r3"))
    try:
        assert "debris" in w.stages and sorted(w.allocations) == ["debris", "rigid"]
    finally:
        w.release()


@pytest.mark.parametrize("scene, option, kind, frames", [
    ("glass_r3", "sphere_capacity", "spheres", 1),
    ("rigid_pile", "contact_capacity", "contacts", 3),
])
def test_a_store_too_small_grows_and_names_the_scene_option(capsys, scene, option, kind, frames):
    """With scene.sphere_capacity (contact_capacity) below the scene's boundary spheres (contacts), the
    rigid store grows (the run goes on, the same as with room) and the note names the option that
    avoids the pause."""
    from scenes.loader import load_scene
    from sim.guards import state_hash
    from sim.world import World

    hashes = []
    for extra in ([], [f"scene.{option}=1"]):
        w = World(load_scene(scene, ['scene.effects=["rigid"]', *extra]))
        try:
            for _ in range(frames):
                w.step_frame()
            hashes.append((w.rigid.grow_count, state_hash(w)))
        finally:
            w.release()
    assert hashes[0][0] == 0 and hashes[1][0] >= 1 and hashes[0][1] == hashes[1][1]
    err = capsys.readouterr().err
    assert f"rigid {kind} exceed the store's 16" in err and f"scene.{option} >=" in err
