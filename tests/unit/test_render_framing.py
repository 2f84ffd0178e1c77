"""The camera of headless runs (render/framing.py): frames the bodies at once, keeps every corner of
their bounds inside the image at every frame while they spread, moves without jumps, and keeps the
file's camera in 'fixed' mode."""

from __future__ import annotations

import numpy as np

from render.camera import Camera, box_corners
from render.framing import MARGIN, SMOOTHING, FollowCamera

W, H = 320, 240


def _inside(cam: Camera, lo, hi) -> bool:
    corners = box_corners(lo, hi)
    px, _, _ = cam.project(corners, W, H)
    return bool(np.all((px[:, 0] >= 0) & (px[:, 0] <= W) & (px[:, 1] >= 0) & (px[:, 1] <= H)))


def _spreading(t: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of pieces flying apart from a point 0.5 m up, then resting on the floor (t in frames)."""
    s = min(t, 40.0)
    lo = np.array([-0.05 - 0.02 * s, max(0.5 - 0.02 * t, 0.0), -0.05 - 0.01 * s])
    hi = np.array([0.05 + 0.03 * s, max(0.6 - 0.02 * t, 0.05), 0.05 + 0.015 * s])
    return lo, hi


def test_every_frame_keeps_the_bodies_in_view_without_jumps():
    base = Camera(eye=[0.8, 0.6, 0.8], target=[0.0, 0.1, 0.0], fov_deg=45.0)
    follow = FollowCamera(base, W / H, floor_y=0.0)
    prev = None
    for t in range(120):
        lo, hi = _spreading(float(t))
        cam = follow.update(lo, hi)
        assert _inside(cam, lo, hi)
        assert _inside(cam, [lo[0], 0.0, lo[2]], [hi[0], 0.0, hi[2]])  # the floor under the pieces too
        assert np.allclose(cam.basis()[2], base.basis()[2])  # the file's view direction is kept
        if prev is not None:  # no jumps: the target moves at most SMOOTHING of the way to the goal
            lo0, hi0 = _spreading(float(t - 1))
            span = float(np.linalg.norm(np.maximum(hi, hi0) - np.minimum(lo, lo0)))
            assert np.linalg.norm(cam.target - prev.target) <= SMOOTHING * span + 1e-9
        prev = cam.copy()


def test_first_frame_is_fitted_tightly():
    """At the first frame the box fills the image up to the margin along one side."""
    base = Camera(eye=[0.0, 0.3, 1.0], target=[0.0, 0.0, 0.0], fov_deg=45.0)
    lo, hi = np.array([-0.1, 0.0, -0.1]), np.array([0.1, 0.2, 0.1])
    cam = FollowCamera(base, W / H, floor_y=0.0).update(lo, hi)
    corners = box_corners(lo, hi)
    px, _, _ = cam.project(corners, W, H)
    half = np.array([W, H]) / 2
    reach = np.max(np.abs(px - half) / half)
    assert abs(reach - 1.0 / MARGIN) < 1e-4  # Camera.fit pads the box by 1e-6 of its size


def test_fixed_mode_keeps_the_scene_camera():
    base = Camera(eye=[0.8, 0.6, 0.8], target=[0.0, 0.1, 0.0])
    follow = FollowCamera(base, W / H, floor_y=0.0, follow=False)
    cam = follow.update(*_spreading(30.0))
    assert np.allclose(cam.eye, base.eye) and np.allclose(cam.target, base.target)
