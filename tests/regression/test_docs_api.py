"""docs/api.md matches the code: its Python blocks run, in order, in a fresh process (the page
promises that every block runs as it stands)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_api_page_examples_run(tmp_path):
    text = (ROOT / "docs" / "api.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    script = "import matplotlib\nmatplotlib.use('Agg')\n" + "\n".join(blocks)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=900,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert r.returncode == 0, r.stderr[-3000:]
    assert "materials[0].cracks = 0 is invalid" in r.stdout
    assert {p.name for p in tmp_path.iterdir()} >= {"pane.obj", "pane.vtu", "pot_end.png"}
