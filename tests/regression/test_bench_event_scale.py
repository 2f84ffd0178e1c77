"""bench/bench_event_scale.py (issue 16, item 3) runs and prints its table: one row per scene size,
particles in proportion to the pots, every time finite and > 0 (nothing is timed here)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_event_scale_benchmark_prints_a_row_per_scene_size():
    out = subprocess.run([sys.executable, "bench/bench_event_scale.py", "--counts", "1,2", "--repeat", "1"],
                         capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = [line.strip("|").split("|") for line in out.stdout.splitlines() if line.startswith("| ") and
            line[2].isdigit()]
    assert [int(r[0]) for r in rows] == [1, 2]
    particles = [int(r[1].replace(",", "")) for r in rows]
    assert particles[1] == 2 * particles[0]  # two identical pots
    times = [float(c) for r in rows for c in r[2:]]
    assert len(times) == 8 and all(math.isfinite(t) and t > 0.0 for t in times)
    assert "fracture in place" in out.stdout
