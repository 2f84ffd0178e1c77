"""The accuracy-vs-cost report (`python main.py bench --quick`) is complete and its numbers are sane.

Runs `bench.report.main(["--quick", "--out", tmp])`. The report runs every sweep in its own process
(Taichi's precision is fixed per process), so this f64 test session does not constrain it. Checked:
every sweep's section and plot is there, every Markdown table parses (same cell count in every row),
every number is finite and > 0 except in columns marked `*` (0 allowed where a setting is exact by
construction: adaptive subdivision's cut, corrected gradients of linear fields, a penetration held
off by speculative contacts), results.json holds only finite numbers, and adaptive subdivision's
surface error is below basic removal's at equal resolution. Nothing is timed here (the report
measures times, the test only checks they are positive).
"""

from __future__ import annotations

import json
import math
import re

import pytest

SECTIONS = {
    "## 1. Fracture surface": "fracture.png",
    "## 2. SPH gradient": "gradient.png",
    "## 3. Elastic cantilever": "beam.png",
    "## 4. Boundary-particle sampling": "sampling.png",
    "## 5. Precision": "precision.png",
    "## 6. The paper's scenarios": None,
}
NUMBER = re.compile(r"^[+-]?(\d{1,3}(,\d{3})+|\d+)(\.\d+)?([eE][+-]?\d+)?$")
BAD = re.compile(r"\b(nan|inf|-inf)\b", re.IGNORECASE)

pytestmark = pytest.mark.slow  # the quick report takes about 90 s: CI's slow pass runs it


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from bench.report import main

    out = tmp_path_factory.mktemp("bench_report")
    rc = main(["--quick", "--out", str(out)])
    return rc, out


def tables(text: str) -> list[tuple[list[str], list[list[str]]]]:
    """Every Markdown table: (header cells, body rows of cells)."""
    out = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and re.match(r"^\|(-+\|)+$", lines[i + 1].strip()):
            head = [c.strip() for c in lines[i].strip().strip("|").split("|")]
            rows = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            out.append((head, rows))
        else:
            i += 1
    return out


def test_report_runs_and_has_every_section(report):
    rc, out = report
    assert rc == 0
    text = (out / "README.md").read_text()
    assert "```\n.venv/bin/python main.py bench --quick" in text  # the command to reproduce, at the top
    assert text.index("Reproduce with") < text.index("## 1.")
    for title, png in SECTIONS.items():
        assert title in text, title
        if png:
            assert f"]({png})" in text, png
            data = (out / png).read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000, png
    assert "CPU" in text and "Taichi" in text and "CUDA" in text  # machine and versions are named


def test_tables_parse_and_numbers_are_finite_and_positive(report):
    _, out = report
    text = (out / "README.md").read_text()
    found = tables(text)
    assert len(found) >= 8  # header facts, run times, one per sweep, two for the scenes
    checked = 0
    for head, rows in found:
        assert rows, head
        for row in rows:
            assert len(row) == len(head), (head, row)
            for col, cell in zip(head, row):
                assert not BAD.search(cell), (col, cell)
                if NUMBER.match(cell):
                    value = float(cell.replace(",", ""))
                    assert math.isfinite(value), (col, cell)
                    if col.endswith("*"):
                        assert value >= 0.0, (col, cell)
                    else:
                        assert value > 0.0, (col, cell, row)
                    checked += 1
    assert checked > 100


def test_results_json_is_finite(report):
    _, out = report
    data = json.loads((out / "results.json").read_text())

    def walk(x, path):
        if isinstance(x, float):
            assert math.isfinite(x), path
        elif isinstance(x, dict):
            for k, v in x.items():
                walk(v, f"{path}.{k}")
        elif isinstance(x, list):
            for k, v in enumerate(x):
                walk(v, f"{path}[{k}]")

    walk(data, "results")
    assert {"fracture", "gradient", "beam", "sampling", "precision", "scenes"} <= set(data)


def test_adaptive_subdivision_beats_basic_removal(report):
    _, out = report
    rows = json.loads((out / "results.json").read_text())["fracture"]["rows"]
    for k in {r["k_base"] for r in rows}:
        by = {r["mode"]: r for r in rows if r["k_base"] == k}
        assert by["subdivision"]["rms_mm"] < by["basic"]["rms_mm"]
        assert by["subdivision"]["volume_error"] < by["basic"]["volume_error"]


def test_both_precisions_and_a_paper_scene_were_measured(report):
    _, out = report
    data = json.loads((out / "results.json").read_text())
    assert {r["precision"] for r in data["precision"]["rows"]} == {"f32", "f64"}
    scenes = data["scenes"]["rows"]
    assert scenes and all(r["events"] for r in scenes)  # the window contains a fracture event
    beam = data["beam"]
    try:
        import pysplishsplash  # noqa: F401

        assert beam["splishsplash"] == "installed"
    except ImportError:
        assert beam["splishsplash"] == "not installed"
        assert "not installed" in (out / "README.md").read_text()
