"""render/prewarm.py's memory of a scene's buffer sizes: read back as written, a damaged or foreign
file gives nothing (a frame never depends on it), the oldest scenes are forgotten first, and an
unwritable folder only loses the hint. (The pre-warm itself: tests/regression/test_draw_process.py.)"""

from __future__ import annotations

import json

from render import prewarm

SIZES = dict(tri_capacity=17626, body_capacity=512, particle_capacity=6501, line_capacity=0)


def test_sizes_are_remembered_by_key(tmp_path):
    assert prewarm.remembered(tmp_path, "a") is None
    prewarm.remember(tmp_path, "a", dict(SIZES, lighting="not a size"))
    prewarm.remember(tmp_path, "b", dict(SIZES, tri_capacity=2))
    assert prewarm.remembered(tmp_path, "a") == SIZES
    assert prewarm.remembered(tmp_path, "b")["tri_capacity"] == 2
    assert [p.name for p in tmp_path.iterdir()] == [prewarm.HINTS_FILE]  # no temporary file left


def test_a_damaged_file_gives_nothing(tmp_path):
    path = tmp_path / prewarm.HINTS_FILE
    for text in ("{", "[1, 2]", json.dumps({"a": {"tri_capacity": -1}}),
                 json.dumps({"a": dict(SIZES, tri_capacity="many")}), json.dumps({"a": dict(SIZES, extra=1)})):
        path.write_text(text)
        assert prewarm.remembered(tmp_path, "a") is None, text
    prewarm.remember(tmp_path, "a", SIZES)  # a damaged file is replaced
    assert prewarm.remembered(tmp_path, "a") == SIZES


def test_the_oldest_scenes_are_forgotten_first(tmp_path):
    for k in range(prewarm.MOST_HINTS + 3):
        prewarm.remember(tmp_path, f"k{k}", SIZES)
    prewarm.remember(tmp_path, "k5", dict(SIZES, body_capacity=8))  # asked again: the newest now
    kept = json.loads((tmp_path / prewarm.HINTS_FILE).read_text())
    assert len(kept) == prewarm.MOST_HINTS
    assert "k2" not in kept and "k3" in kept and list(kept)[-1] == "k5"


def test_an_unwritable_folder_loses_only_the_hint(tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("")
    prewarm.remember(blocked / "sub", "a", SIZES)  # a folder that cannot be made
    assert prewarm.remembered(blocked / "sub", "a") is None


def test_the_key_is_the_scenes_content_not_its_files_place(tmp_path):
    """sim.run.scene_key: the same scene file copied elsewhere (a clone, a worktree) keys the same
    remembered sizes; another scene content, size or renderer keys others."""
    import shutil
    from pathlib import Path

    from scenes.loader import load_scene
    from sim.run import RunOptions, scene_key

    shutil.copy(Path(__file__).resolve().parents[2] / "scenes" / "pot.toml", tmp_path / "pot.toml")
    opts = RunOptions(out=tmp_path / "out")
    here, there = load_scene("pot"), load_scene(str(tmp_path / "pot.toml"))
    assert here.source != there.source
    assert scene_key(here, opts) == scene_key(there, opts)
    assert scene_key(here, opts) != scene_key(load_scene("pot", ["objects.pot.position=[0,0.2,0]"]), opts)
    assert scene_key(here, opts) != scene_key(here, RunOptions(out=tmp_path / "out", width=320, height=240))
