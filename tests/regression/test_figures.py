"""`main.py figures` plumbing on a small scene: the sheet's image has one row of three labelled frames
per scene (before, during and after the first fracture event, in that order), and the Markdown
carries the caption, the counts beside Table 1 and the command."""

from __future__ import annotations

import numpy as np
from PIL import Image

from sim.figures import LABEL_PX, PANEL_PX, Figure, Row, make_sheet


def test_sheet_of_a_scripted_cut(tmp_path, taichi_runtime):
    fig = Figure(99, "A tet cut in two (test)", (Row("tet_cut_22", "scripted 2-2 cut", "Test", 2),), "Nothing.")
    out = make_sheet(tmp_path / "figures.md", frames=12, progress=False, figures=(fig,))
    text = out.read_text()
    assert "## Fig. 99" in text and "> A tet cut in two (test)" in text
    assert "| tet_cut_22 | scripted 2-2 cut |" in text and "2 (Test)" in text
    assert "`python main.py run tet_cut_22`" in text and "**What still differs.** Nothing." in text
    img = np.asarray(Image.open(tmp_path / "figures" / "fig99.png"))
    w, h = PANEL_PX
    assert img.shape == (h + LABEL_PX, 3 * w, 3)
    frames = [img[LABEL_PX:, k * w:(k + 1) * w] for k in range(3)]
    assert not np.array_equal(frames[0], frames[2])  # the cut pieces moved between before and after
