"""bench/bench_scenes.py (`main.py bench --scenes`): the table is computed from the runs' own records.

The runs themselves are a benchmark (never timed in a test); here the summary of two synthetic
stats.json records is checked against hand-computed figures, and the README writer is checked to
replace only what lies between its markers.
"""

from __future__ import annotations

import pytest

from bench import bench_scenes as bs


def stats(frame_ms: list[float], events: list[dict], scripted: list[bool] | None = None,
          stages: list[dict] | None = None) -> dict:
    scripted = scripted or [False] * len(events)
    return {
        "frames": len(frame_ms),
        "events": [{"scripted": s} for s in scripted],
        "table1": {"fragments": 7, "pieces": {"debris": 4, "small": 1, "large": 2, "total": 7}},
        "timings": {"frame_wall_ms": frame_ms, "wall_s": sum(frame_ms) / 1e3, "build_s": 0.5,
                    "per_frame_ms": stages or [{"rigid": 1.0}] * len(frame_ms),
                    "table2_events": events, "first_frame_unix": 1000.0 + frame_ms[0] / 1e3},
        "_bench": {"launched": 999.0, "peak_mb": 321.0},
    }


def test_summary_figures_are_the_runs_own():
    frame_ms = [900.0] + [50.0] * 9 + [100.0] * 10  # 20 frames: the first 10% (2) are left out of "steady"
    ev = [dict(stress_analysis_ms=10.0, particle_subdivision_ms=20.0, crack_generation_ms=30.0, whole_event_ms=70.0),
          dict(stress_analysis_ms=2.0, particle_subdivision_ms=0.0, crack_generation_ms=4.0, whole_event_ms=9.0),
          dict(stress_analysis_ms=0.0, particle_subdivision_ms=5.0, crack_generation_ms=5.0)]  # scripted: left out
    r = bs.summarise("pot", stats(frame_ms, ev, [False, False, True]), stats([10.0] * 20, []))
    assert (r["events"], r["stress_ms"], r["subdivision_ms"], r["crack_ms"]) == (2, 6.0, 10.0, 17.0)
    assert (r["event_ms"], r["first_event_ms"]) == (39.5, 70.0)
    assert r["fps_drawn"] == pytest.approx(1e3 * 18 / (8 * 50.0 + 10 * 100.0))
    assert r["fps_window"] == pytest.approx(1e3 * 19 / (9 * 50.0 + 10 * 100.0))  # a run shorter than 62 frames
    assert bs.window_fps([900.0] + [50.0] * 61 + [1000.0] * 5) == pytest.approx(20.0)  # frames 1-61 only
    assert r["fps_bare"] == pytest.approx(100.0)
    assert r["fps_average"] == pytest.approx(20 / 2.35)
    assert r["longest_ms"] == 100.0  # after the first frame
    assert r["quiet_longest_ms"] == 100.0  # no frame had an event
    # frames 10-19 analysed an impact (one of them also split a body): the longest without is frame 1-9's
    stages = [{"rigid": 1.0}] * 10 + [{"rigid": 1.0, "fracture.analysis": 5.0}] * 9 + [
        {"rigid": 1.0, "fracture.analysis": 5.0, "fracture.split": 4.0}]
    assert bs.summarise("pot", stats(frame_ms, ev, stages=stages), stats([10.0] * 20, []))["quiet_longest_ms"] == 50.0
    assert bs.summarise("pot", stats(frame_ms, ev, stages=[{"fracture.analysis": 1.0}] * 20),
                        stats([10.0] * 20, []))["quiet_longest_ms"] is None
    assert r["first_frame_s"] == pytest.approx(1.9) and r["peak_mb"] == 321.0
    later = [stats([2500.0, 10.0], []), stats([1500.0, 10.0], [])]  # two more launches: 3.5 s and 2.5 s
    median = bs.summarise("pot", stats(frame_ms, ev), stats([10.0] * 20, []), later)["first_frame_s"]
    assert median == pytest.approx(2.5)  # of 1.9, 3.5 and 2.5 s
    row = bs.table([r]).splitlines()[2]
    assert row.startswith("| pot | 20 | 2 | 6.0 (86) | 10.0 (2,869) | 17.0 (1,505) | 39.5 (70) | 12.9 | 13.1 |")
    assert bs.counts_table([r]).splitlines()[2] == "| pot | 7 (4 / 1 / 2) | 14 | 0.50x | yes |"


def test_targets_table_names_the_scenes_that_miss():
    quick = [900.0] + [50.0] * 9 + [100.0] * 10  # starts in 1.9 s, nothing over 100 ms
    slow = [2500.0] + [150.0] * 19  # starts in 3.5 s, 6.7 frames/s, 150 ms frames
    ev = [dict(stress_analysis_ms=1.0, particle_subdivision_ms=2.0, crack_generation_ms=3.0, whole_event_ms=12.0),
          dict(stress_analysis_ms=1.0, particle_subdivision_ms=2.0, crack_generation_ms=3.0, whole_event_ms=20.0)]
    pot = bs.summarise("pot", stats(quick, ev), stats([10.0] * 20, []))  # events 16.0 ms mean: not under 16
    pots = bs.summarise("pots", stats(slow, []), stats([1000.0] * 20, []))  # 1.0 frames/s not drawn, 1.3 in the paper
    pet = bs.summarise("pet", stats(quick, []), stats([10.0] * 20, []))
    lines = bs.targets_table([pot, pots, pet]).splitlines()
    assert lines[2] == ("| every paper scene at or above its Table 2 frame rate, not drawn (paper) "
                        "| pot 100.0 (10.2), pots 1.0 (1.3), pet 100.0 (1.2) | not for pots |")
    assert lines[3] == ("| the first frame under 3 s with warm caches (s) | pot 1.90, pots 3.50, pet 1.90 "
                        "| not for pots |")
    assert lines[4] == ("| no frame over 100 ms outside fracture events (ms) | pot 100, pots 150, pet 100 "
                        "| not for pots |")
    assert lines[5] == ("| a Pot fracture event under 16 ms, the first included (ms: mean, first) | pot 16.0, 12 "
                        "| not for pot |")
    assert lines[6] == "| Pots at 10 frames/s or more, drawn, frames 1-61 | pots 6.7 | not for pots |"
    assert lines[7] == "| the Pet built in under 5 s and 500 MB (s, MB) | pet 0.50, 321 | yes |"
    assert len(bs.targets_table([pet]).splitlines()) == 6  # the pot's and Pots' own targets need their runs


def test_readme_table_is_replaced_between_its_markers_only(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{bs.README_BEGIN}\nold table\n{bs.README_END}\nafter\n")
    bs.write_readme("new table", readme)
    assert readme.read_text() == f"before\n{bs.README_BEGIN}\nnew table\n{bs.README_END}\nafter\n"
    readme.write_text("no markers\n")
    with pytest.raises(SystemExit, match="markers"):
        bs.write_readme("x", readme)


def test_unknown_scene_is_refused_in_one_line(capsys):
    assert bs.main(["--only", "pot,nope"]) == 2
    assert "--only nope: not a paper scene" in capsys.readouterr().err


def test_cuda_without_a_device_and_a_cuda_readme_are_refused(capsys, monkeypatch):
    import core.runtime

    monkeypatch.setattr(core.runtime, "cuda_available", lambda: False)
    assert bs.main(["--only", "pot", "--arch", "cuda"]) == 2
    assert "no CUDA device" in capsys.readouterr().err
    monkeypatch.setattr(core.runtime, "cuda_available", lambda: True)
    assert bs.main(["--only", "pot", "--arch", "cuda", "--readme"]) == 2
    assert "README's CPU table" in capsys.readouterr().err
