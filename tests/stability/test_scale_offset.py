"""Units and offsets: the same scene with its mesh file in metres and in millimetres, and translated far
from the origin, gives the same fragments (a ball breaks a glass slab held at its border)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from scenes.loader import scene_from_dict
from sim.world import World
from tests.stability.helpers import GLASS, ROOT, STEEL, material

SLAB = (0.16, 0.16, 0.01)  # m


def write_obj(path, vertices, faces) -> str:
    with open(path, "w") as f:
        for v in vertices:
            f.write("v " + " ".join(repr(float(c)) for c in v) + "\n")
        for t in faces:
            f.write("f " + " ".join(str(int(i) + 1) for i in t) + "\n")
    return str(path)


def slab_files(folder) -> dict:
    import trimesh

    box = trimesh.creation.box(extents=SLAB)
    return {"m": write_obj(folder / "slab_m.obj", box.vertices, box.faces),
            "mm": write_obj(folder / "slab_mm.obj", np.asarray(box.vertices) * 1000.0, box.faces)}


def slab_scene(mesh: str, units: str, offset=(0.0, 0.0, 0.0)) -> dict:
    off = [float(c) for c in offset]

    def at(*p):
        return [o + c for o, c in zip(off, p)]

    return {
        "scene": {"name": "slab", "effects": ["rigid", "fracture", "subdivision", "shatter"], "frames": 8},
        "materials": [
            material("glass", GLASS, 2500.0, tensile_strength=4e7, toughness=8.0, restitution=0.1, friction=0.4,
                     cracks=4, kernel={"mode": "fixed", "support": 2.0, "axis_scale": [2.0, 2.0, 1.0]}),
            material("steel", STEEL, 7800.0, restitution=0.3, friction=0.4),
        ],
        "objects": [
            {"name": "slab", "mesh": mesh, "units": units, "material": "glass", "resolution": 0.02,
             "position": at(0.0, 0.3, 0.0), "static": True, "held_border": 0.02},
            {"name": "ball", "shape": {"type": "sphere", "radius": 0.02}, "material": "steel", "resolution": 0.012,
             "position": at(0.01, 0.31, 0.04), "velocity": [0.0, 0.0, -15.0], "breakable": False},  # splits the slab
        ],
        "colliders": [{"type": "plane", "normal": [0.0, 1.0, 0.0], "point": at(0.0, 0.0, 0.0)}],
    }


def fragments(raw: dict, offset=(0.0, 0.0, 0.0), frames: int = 8) -> dict:
    """Fragment masses (kg) and centres of mass (m, offset removed), sorted by mass then x."""
    w = World(scene_from_dict(raw, "slab"))
    try:
        for _ in range(frames):
            w.step_frame()
        st = w.rigid.body_state()
        ids = np.flatnonzero(st.alive)
        mass = np.array([w.rigid.body_mass(int(b)) for b in ids])
        x = st.x[ids] - np.asarray(offset)
        order = np.lexsort((x[:, 0], mass))
        # count: the moving pieces (bodies); debris: the shattered grains, counted apart (World.pieces)
        return dict(events=len(w.events), count=len(ids), debris=w.debris_pieces, alive=int(w.particles.alive.sum()),
                    mass=mass[order], x=x[order], physical=w.physical_count)
    finally:
        w.release()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return slab_files(tmp_path_factory.mktemp("slab"))


@pytest.fixture(scope="module")
def reference(files):
    ref = fragments(slab_scene(files["m"], "m"))
    assert ref["events"] >= 1 and ref["count"] >= 3  # precondition: the slab breaks
    return ref


def test_millimetre_file_gives_the_same_fragments(files, reference):
    mm = fragments(slab_scene(files["mm"], "mm"))
    assert mm["physical"] == reference["physical"] and mm["count"] == reference["count"]
    # x_mm * 0.001 rounds to the same metres here: identical to the bit
    assert np.array_equal(mm["mass"], reference["mass"]) and np.array_equal(mm["x"], reference["x"])


@pytest.mark.parametrize("offset", [1e3, 1e5])
def test_translated_scene_gives_the_same_fragments(files, reference, offset):
    """f64: the whole scene (slab, ball, floor) moved by (d, d, d): same fragments, masses within 1e-7
    relative and centres of mass within 1e-8 m. The crack point is the foot of the ball's centre on the
    struck face (sim.struck_surface.surface_frame); at 1e5 m the rigid integration keeps that centre to
    about 1e-9 m, which moves the cut by as much (measured: masses 2e-12 relative at 1e3 m, 1.5e-8 at 1e5 m)."""
    d = (offset, offset, offset)
    far = fragments(slab_scene(files["m"], "m", d), d)
    assert far["count"] == reference["count"] and far["alive"] == reference["alive"]
    assert far["debris"] == reference["debris"]
    assert np.abs(far["mass"] - reference["mass"]).max() <= 1e-7 * reference["mass"].max()
    assert np.abs(far["x"] - reference["x"]).max() <= 1e-8


F32_PROBE = """
import json, sys
sys.path.insert(0, {root!r})
from core.runtime import init_taichi
init_taichi("cpu", "f32", threads=1)
from tests.stability.test_scale_offset import fragments, slab_scene
out = {{}}
for d in (0.0, 10.0, 1000.0):
    r = fragments(slab_scene({mesh!r}, "m", (d, d, d)), (d, d, d))
    out[str(d)] = dict(count=r["count"], debris=r["debris"], alive=r["alive"], mass=r["mass"].tolist(),
                       x=r["x"].tolist())
print(json.dumps(out))
"""


@pytest.mark.slow
def test_translated_scene_in_single_precision(files):
    """f32 (the default of `main.py run`): positions are resolved to ulp(|x|), so the contact point and
    the cut move with the offset. At 10 m: masses within 1e-4 relative, centres within 0.5 mm; at 1e3 m
    the body count holds to one piece (the shattered grains within 3%) but masses differ by up to 3e-2
    and centres by up to 2 cm (measured: 1.7e-2; the crack point is the foot of the striker's centre,
    which f32 keeps to 6e-5 m there, and the ball's radius of curvature fitted for Hertz moves by 1.5%,
    and the shatter and plug radii with it: a particle wedged between two cracks at the rim of the
    shattered zone can come free as a piece of its own) - docs/robustness.md: keep f32 scenes near the
    origin, or run with --precision f64."""
    r = subprocess.run([sys.executable, "-c", F32_PROBE.format(root=str(ROOT), mesh=files["m"])], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    ref = res["0.0"]
    for d, mass_tol, x_tol, pieces in (("10.0", 1e-4, 5e-4, 0), ("1000.0", 3e-2, 2e-2, 1)):
        far = res[d]
        assert abs(far["count"] - ref["count"]) <= pieces
        # a grain at the edge of the shattered zone may fall either side of r_inner at ulp(|x|); at 1e3 m
        # the radii move by up to 1.5% (docstring), and the grains of a plate's shattered and crushed
        # zones go as their radius squared: up to 3% (a particle crossing r_crush is 4 grains or 1)
        assert abs(far["debris"] - ref["debris"]) <= max(3, 0.03 * ref["debris"])
        # each reference piece against the far piece nearest to it (an extra wedge has no partner)
        x, x0 = np.array(far["x"]), np.array(ref["x"])
        m, m0 = np.array(far["mass"]), np.array(ref["mass"])
        match = np.argmin(np.linalg.norm(x0[:, None] - x[None], axis=2), axis=1)
        assert len(np.unique(match)) == len(x0)
        assert np.abs(m[match] - m0).max() <= mass_tol * m0.max()
        assert np.abs(x[match] - x0).max() <= x_tol
