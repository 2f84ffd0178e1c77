"""The viewer in a real window under Xvfb (`xvfb-run ... main.py view tet_cut_31 --frames 30 --script ...`):
it starts, runs frames with a scripted strike and a toggle change, and its screenshot shows the object
and the ImGui panel. Skipped only where xvfb-run (tools/system_deps.sh installs it) or Vulkan is missing.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from render.camera import Camera
from render.scene_data import Lighting
from render.session import FLOOR_COLOR
from viewer.panel import panel_fraction

ROOT = Path(__file__).resolve().parents[2]
W, H = 800, 600
XVFB = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24"]
TIMEOUT_S = 300


def _tet_corners_world(cfg) -> np.ndarray:
    """World corners of the scene's tet at rest (the scripted crack only splits it where it stands)."""
    from geometry.build import build_object

    o = cfg.objects[0]
    params = dict(o.shape)
    kind = params.pop("type")
    geo = build_object(kind, resolution=o.resolution, shape_params=params)
    return geo.mesh.verts + np.asarray(o.position)


@pytest.fixture(scope="module")
def viewer_run(tmp_path_factory):
    if shutil.which("xvfb-run") is None:
        pytest.skip("xvfb-run not found: install xvfb and xauth (tools/system_deps.sh does it as root)")
    from render.ggui import vulkan_status

    ok, why = vulkan_status()
    if not ok:
        pytest.skip(f"no Vulkan driver for GGUI ({why}): install mesa-vulkan-drivers (tools/system_deps.sh)")
    out = tmp_path_factory.mktemp("viewer")
    shot = out / "shot.png"
    cmd = XVFB + [sys.executable, str(ROOT / "main.py"), "view", "tet_cut_31", "--width", str(W), "--height", str(H),
                  "--frames", "30", "--script", f"strike@10,toggle@12:particles,shot@20:{shot}"]
    env = {**os.environ, "TI_LOG_LEVEL": "error"}
    res = subprocess.run(cmd, cwd=out, capture_output=True, text=True, timeout=TIMEOUT_S, env=env)
    return res, shot, out


def test_viewer_starts_runs_and_exits(viewer_run):
    res, shot, out = viewer_run
    assert res.returncode == 0, res.stderr[-3000:]
    assert "viewer frame 10: strike" in res.stderr  # the scripted strike ran (a crack or 'no crack')
    assert shot.exists()
    assert not (out / "imgui.ini").exists()  # the viewer removes the ImGui file it caused


def test_screenshot_shows_object_and_panel(viewer_run):
    """The PNG has the window size; inside the tet's projected bounding box many pixels are neither the
    background nor the floor colour (the object is drawn); the panel rectangle holds ImGui's dark window
    colour and its blue title bar, which neither the background nor the floor has."""
    from PIL import Image

    from scenes.loader import load_scene

    res, shot, _ = viewer_run
    assert res.returncode == 0, res.stderr[-3000:]
    img = np.asarray(Image.open(shot).convert("RGB")).astype(np.int64)
    assert img.shape == (H, W, 3)
    cfg = load_scene("tet_cut_31")
    cam = Camera(eye=cfg.camera.eye, target=cfg.camera.target, fov_deg=cfg.camera.fov)
    px, _, _ = cam.project(_tet_corners_world(cfg), W, H)
    x0, y0 = np.floor(px.min(0)).astype(int)
    x1, y1 = np.ceil(px.max(0)).astype(int)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    assert x1 - x0 > 20 and y1 - y0 > 20
    lt = Lighting()
    bg = np.rint(lt.background * 255)
    n_dot_l = lt.light_dir @ np.array([0.0, 1.0, 0.0])
    floor = np.rint(np.asarray(FLOOR_COLOR) * (lt.ambient + lt.light_color * n_dot_l) * 255)
    box = img[y0:y1, x0:x1].reshape(-1, 3)
    other = (np.abs(box - bg).max(1) > 12) & (np.abs(box - floor).max(1) > 12)
    assert other.mean() > 0.2, f"object pixels {other.mean():.3f} in box {(x0, y0, x1, y1)}"
    left = int(np.ceil((1.0 - panel_fraction(W)) * W)) + 2
    panel = img[30:H - 10, left:W - 20].reshape(-1, 3)
    dark = panel.max(1) <= 30  # ImGui's window background (about 16, 16, 17)
    assert dark.mean() > 0.4, f"dark panel pixels {dark.mean():.3f}"
    assert np.abs(bg - 16).max() > 12 and np.abs(floor - 16).max() > 12  # neither looks like the panel
    title = img[2:16, left:W - 20].reshape(-1, 3)
    assert np.mean(title[:, 2] - title[:, 0] > 40) > 0.5  # the blue title bar
    text = panel.min(1) > 180
    assert text.sum() > 200  # white text in the panel
