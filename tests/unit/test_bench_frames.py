"""bench/bench_frames.py: the README's frame-cost table is the benchmark's output (issue 16, "An honest
table"): its rows from the measured means, written between the README's markers, and a --readme run
that would measure something else is refused."""

from __future__ import annotations

import pytest

from bench import bench_frames as bf
from bench.bench_scenes import ROOT


def test_the_readme_rows_are_the_measured_means():
    m = dict(scene="pot", sim_mean_ms=34.04, render_mean_ms=90.46, ratio=90.46 / 34.04)
    assert bf.readme_table([m]).splitlines() == ["| scene | simulation ms | rendering ms | render / sim |",
                                                  "|---|---|---|---|", "| pot | 34.0 | 90.5 | 2.66 |"]


def test_the_readme_holds_the_frame_table_markers_once():
    text = (ROOT / "README.md").read_text()
    assert text.count(bf.README_BEGIN) == 1 and text.count(bf.README_END) == 1
    assert text.index(bf.README_BEGIN) < text.index(bf.README_END)


def test_a_readme_run_with_other_options_is_refused(capsys):
    with pytest.raises(SystemExit):
        bf.main(["--readme", "--quick"])
    assert "--readme measures the README's scenes" in capsys.readouterr().err
