"""Bad scene files get an error naming the key path, the value and the allowed range; nothing is
written. Overrides on the command line are validated like the file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from core.errors import ConfigError
from scenes.loader import load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[2]

GOOD = """
[scene]
name = "t"
effects = ["rigid"]
frames = 2

[[materials]]
name = "m"
density = 1000.0
stiffness = { model = "isotropic", E = 1.0e9, nu = 0.3 }

[[objects]]
name = "o"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
material = "m"
resolution = 0.05
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scene.toml"
    p.write_text(text)
    return p


def error_for(tmp_path, text: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_scene(str(write(tmp_path, text)))
    return info.value


def test_good_scene_loads(tmp_path):
    cfg = load_scene(str(write(tmp_path, GOOD)))
    assert cfg.objects[0].resolution == 0.05 and cfg.scene.frames == 2


@pytest.mark.parametrize(
    "change,key,allowed",
    [
        (("frames = 2", "frames = 2\ncolour = 3"), "scene.colour", "a known key"),
        (("frames = 2", 'frames = "two"'), "scene.frames", "an integer"),
        (("resolution = 0.05", "resolution = nan"), "objects[0].resolution", "finite"),
        (("resolution = 0.05", "resolution = inf"), "objects[0].resolution", "finite"),
        (("E = 1.0e9", "E = -1.0e9"), "E", "> 0"),
        (("nu = 0.3", "nu = 0.5"), "nu", "0.5"),
        (('effects = ["rigid"]', 'effects = ["rigid", "lasers"]'), "scene.effects[1]", "one of"),
        (('effects = ["rigid"]', 'effects = ["rigid", "subdivision"]'), "scene.effects", "needs 'fracture'"),
        (("density = 1000.0", "density = 1000.0\nrestitution = 1.5"), "materials[0].restitution", "<= 1"),
        (("density = 1000.0", "density = 1000.0\nfriction = -0.1"), "materials[0].friction", ">= 0"),
        (('material = "m"', 'material = "nope"'), "objects[0].material", "a material named"),
        (('shape = { type = "box", size = [0.1, 0.1, 0.1] }', 'mesh = "x.obj"'), "objects[0].units", "length unit"),
        (("size = [0.1, 0.1, 0.1]", "size = [0.1, 0.1, nan]"), "objects[0].shape.size[2]", "finite"),
    ],
)
def test_bad_values_name_key_and_range(tmp_path, change, key, allowed):
    text = GOOD.replace(*change)
    assert text != GOOD
    err = error_for(tmp_path, text)
    msg = str(err)
    assert key in msg, msg
    assert allowed in msg, msg
    assert "scene.toml" in msg


def test_stiffness_not_positive_definite(tmp_path):
    text = GOOD.replace('stiffness = { model = "isotropic", E = 1.0e9, nu = 0.3 }',
                        'stiffness = { model = "anisotropic", stiffness = [[1,2,0,0,0,0],[2,1,0,0,0,0],[0,0,1,0,0,0],'
                        '[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]] }')
    assert "positive definite" in str(error_for(tmp_path, text))


def test_missing_mesh_file_is_named_at_build(tmp_path):
    from sim.world import World

    text = GOOD.replace('shape = { type = "box", size = [0.1, 0.1, 0.1] }', 'mesh = "missing.obj"\nunits = "mm"')
    cfg = load_scene(str(write(tmp_path, text)))
    from core.errors import MeshError

    with pytest.raises(MeshError, match="missing.obj: file not found"):
        World(cfg)


def test_overrides_are_validated_like_the_file():
    cfg = load_scene("rigid_pile", ["scene.frames=7", "materials.wood.friction=0.9", "objects.0.count=2"])
    assert cfg.scene.frames == 7 and cfg.materials[0].friction == 0.9 and cfg.objects[0].count == 2
    with pytest.raises(ConfigError, match="scene.frames"):
        load_scene("rigid_pile", ["scene.frames=0"])
    with pytest.raises(ConfigError, match="materials\\[0\\].friction"):
        load_scene("rigid_pile", ["materials.wood.friction=nan"])
    with pytest.raises(ConfigError, match="--set"):
        load_scene("rigid_pile", ["materials.steel.friction=1"])


def test_overrides_take_dotted_and_bracket_indices_and_list_valid_keys():
    dotted = load_scene("pot", ["objects.0.velocity=[0, -9, 0]", "colliders.0.young=2.0e10"])
    bracket = load_scene("pot", ["objects[0].velocity=[0, -9, 0]", "colliders[0].young=2.0e10"])
    assert dotted.objects == bracket.objects and dotted.colliders == bracket.colliders
    assert bracket.objects[0].velocity == [0.0, -9.0, 0.0] and bracket.colliders[0].young == 2.0e10
    with pytest.raises(ConfigError, match=r"index 0\.\.0 or a name: pot"):
        load_scene("pot", ["objects[3].velocity=[0, -9, 0]"])
    with pytest.raises(ConfigError, match="a known key: angular_velocity, breakable"):
        load_scene("pot", ["objects[0].velocty=[0, -9, 0]"])
    with pytest.raises(ConfigError, match="no empty key"):
        load_scene("pot", ["objects..velocity=1"])


def test_nothing_is_written_for_a_bad_scene(tmp_path):
    bad = write(tmp_path, GOOD.replace("frames = 2", "frames = -1"))
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "main.py", "run", str(bad), "--out", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert "scene.frames" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()


def test_command_line_errors_are_clear(tmp_path):
    cases = [
        (["run", "no_such_scene"], "no_such_scene"),
        (["run", "rigid_pile", "--arch", "cuda", "--out", str(tmp_path / "a")], "cuda"),
        (["run", "rigid_pile", "--out", "/proc/forbidden/x"], "--out"),
        (["run", "rigid_pile", "--threads", "0", "--out", str(tmp_path / "b")], "--threads"),
        (["run", "rigid_pile", "--threads", str((os.cpu_count() or 1) + 1), "--out", str(tmp_path / "c")],
         "this machine's cores"),
    ]
    for args, needle in cases:
        r = subprocess.run([sys.executable, "main.py", *args], cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert r.returncode == 2, (args, r.stderr)
        assert needle in r.stderr and "Traceback" not in r.stderr, r.stderr
        if "--threads" in args:  # refused before Taichi is imported (its banner would be on stdout)
            assert "[Taichi]" not in r.stdout + r.stderr, r.stdout
    assert not (tmp_path / "b").exists() and not (tmp_path / "c").exists()


def test_scene_dict_round_trip():
    import tomllib

    raw = tomllib.loads(GOOD)
    cfg = scene_from_dict(raw, "mem")
    assert cfg.has("rigid") and not cfg.has("fracture")
