"""Headless runs: outputs, reproducibility, and the default scene breaking the pot."""

from __future__ import annotations

import json

import pytest

from scenes.loader import load_scene
from sim.run import RunOptions, run


def stats_without_timings(path):
    data = json.loads(path.read_text())
    data.pop("timings")
    return data


def test_same_run_twice_gives_identical_statistics(tmp_path):
    cfg = load_scene("glass_r3")
    for k in ("a", "b"):
        run(cfg, RunOptions(out=tmp_path / k, frames=6, renderer="none", video="none", progress=False))
    a = stats_without_timings(tmp_path / "a" / "stats.json")
    b = stats_without_timings(tmp_path / "b" / "stats.json")
    assert a["events"], "the ball must break the pane within 6 frames"
    assert a == b


def test_default_scene_breaks_the_pot_and_writes_its_files(tmp_path):
    cfg = load_scene("pot")
    out = tmp_path / "pot"
    stats = run(cfg, RunOptions(out=out, frames=cfg.scene.test_frames, renderer="raster", video="gif",
                                width=160, height=120, progress=False))
    assert stats["table1"]["fragments"] > 1
    assert stats["mass"]["error_kg"] == pytest.approx(0.0, abs=1e-12)
    assert (out / "stats.json").exists() and (out / "pot.gif").exists()
    assert len(list((out / "frames").glob("frame_*.png"))) == cfg.scene.test_frames
    ev = stats["timings"]["table2_events"][0]
    assert ev["stress_analysis_ms"] > 0 and ev["particle_subdivision_ms"] > 0 and ev["crack_generation_ms"] > 0
    # the whole event holds its parts; one wall time per frame, each at least the frame's simulation
    assert ev["whole_event_ms"] >= ev["stress_analysis_ms"] + ev["particle_subdivision_ms"]
    walls, sims = stats["timings"]["frame_wall_ms"], stats["timings"]["per_frame_ms"]
    assert len(walls) == len(sims) == cfg.scene.test_frames
    assert all(w >= 0.99 * sum(s.values()) for w, s in zip(walls, sims))
    assert stats["timings"]["first_frame_unix"] > 0


def test_existing_output_folder_is_not_overwritten(tmp_path):
    from core.errors import ConfigError

    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(ConfigError, match="--overwrite"):
        run(load_scene("rigid_pile"), RunOptions(out=tmp_path, frames=1, renderer="none", video="none"))
    assert (tmp_path / "keep.txt").read_text() == "mine"


def test_an_overwritten_folder_holds_only_the_new_runs_frames(tmp_path):
    """A run of 4 frames into a folder that holds a 6-frame run's frames, meshes and particle series
    (--overwrite) leaves 4 of each, the series file listing 4, and the user's own file."""
    cfg = load_scene("tet_cut_31")
    out = tmp_path / "t"
    opts = dict(out=out, renderer="raster", video="none", width=64, height=48, meshes="obj", vtu=True, progress=False)
    run(cfg, RunOptions(frames=6, **opts))
    (out / "notes.txt").write_text("mine")
    run(cfg, RunOptions(frames=4, overwrite=True, **opts))
    for sub, pattern in (("frames", "frame_*.png"), ("meshes", "frame_*.obj"), ("vtu", "particles_*.vtu")):
        assert len(list((out / sub).glob(pattern))) == 4, sub
    assert (out / "vtu" / "particles.pvd").read_text().count("<DataSet") == 4
    assert (out / "notes.txt").read_text() == "mine"


def test_fragment_meshes_and_vtu_series(tmp_path):
    import meshio
    import trimesh

    cfg = load_scene("tet_cut_31")
    out = tmp_path / "t"
    run(cfg, RunOptions(out=out, frames=3, renderer="none", video="none", meshes="obj", vtu=True, progress=False))
    meshes = sorted((out / "meshes").glob("frame_*.obj"))
    assert len(meshes) == 3
    # after the scripted cut (frame 1) the two closed pieces hold the tet's volume
    tm = trimesh.load(meshes[-1], process=False)
    edge = 0.1
    assert abs(tm.volume) == pytest.approx(edge**3 / (6 * 2**0.5), rel=1e-6)
    series = sorted((out / "vtu").glob("particles_*.vtu"))
    assert len(series) == 3 and (out / "vtu" / "particles.pvd").exists()
    last = meshio.read(series[-1])
    assert len(last.points) == 14 and set(last.point_data["kind"]) == {1}


BOX_ON_FLOOR = """
[scene]
name = "box_drop"
effects = ["rigid"]
frames = 600
[[materials]]
name = "wood"
density = 600.0
stiffness = { model = "isotropic", E = 1.0e10, nu = 0.3 }
[[objects]]
name = "box"
shape = { type = "box", size = [0.1, 0.05, 0.05] }
material = "wood"
resolution = 0.025
position = [0.0, 0.1, 0.0]
breakable = false
[[colliders]]
type = "plane"
"""


def test_a_run_ends_once_everything_rests(tmp_path):
    """A box dropped 7.5 cm comes to rest; the run ends SETTLED_S later (all bodies asleep that long),
    long before the scene's 600 frames, with one PNG per frame written; --all-frames runs them all."""
    from sim.run import SETTLED_S

    path = tmp_path / "box_drop.toml"
    path.write_text(BOX_ON_FLOOR)
    cfg = load_scene(str(path))
    stats = run(cfg, RunOptions(out=tmp_path / "a", renderer="raster", video="none", width=64, height=48,
                                progress=False))
    assert stats["stopped"].startswith("settled")
    fps = cfg.scene.fps
    assert SETTLED_S * fps <= stats["frames"] < 4 * SETTLED_S * fps
    assert len(list((tmp_path / "a" / "frames").glob("frame_*.png"))) == stats["frames"]
    full = run(cfg, RunOptions(out=tmp_path / "b", frames=stats["frames"] + 30, renderer="none", video="none",
                               progress=False, until_settled=False))
    assert full["stopped"] is None and full["frames"] == stats["frames"] + 30
