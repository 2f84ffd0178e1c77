"""A camera that frames the bodies and follows their spread (issue 15, "Framing"; DESIGN.md section 7).

The scene's [camera] gives the view direction (eye - target) and the field of view; with
`camera.mode = "follow"` (the default) the target and the distance follow the bodies:
  * the framed box is the bodies' world bounds (not the floor, not debris particles, which can fly
    far) grown down to the floor, so the floor under the pieces stays in view;
  * the goal is `Camera.fit` of that box (all eight corners inside the image shrunk by MARGIN);
  * target and distance move towards the goal by SMOOTHING per frame (no jumps), except that the
    distance never drops below what keeps every corner inside the image seen from the current,
    smoothed target: pieces never leave the frame, the camera backs off at once and closes in slowly.
The first frame snaps to its goal. `mode = "fixed"` keeps the file's eye and target.
"""

from __future__ import annotations

import numpy as np

from render.camera import Camera

MARGIN = 1.15  # -: the framed box fills at most 1 / MARGIN of the image's half-width and half-height
SMOOTHING = 0.08  # -: share of the way to the goal travelled per frame (time constant ~12 frames)
MIN_EXTENT_M = 0.05  # m: the framed box is at least this big (a resting coin is not filled edge to edge)


class FollowCamera:
    """Per-frame camera for headless runs (module docstring). `update(lo, hi)` -> Camera."""

    def __init__(self, base: Camera, aspect: float, floor_y: float | None = None, follow: bool = True) -> None:
        self.base = base.copy()
        self.aspect = float(aspect)
        self.floor_y = floor_y
        self.follow = follow
        self.camera = base.copy()
        self._target: np.ndarray | None = None
        self._dist = 0.0

    def framed_box(self, lo, hi) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array(lo, dtype=np.float64)
        hi = np.array(hi, dtype=np.float64)
        if self.floor_y is not None:
            lo[1] = min(lo[1], self.floor_y)
        grow = np.maximum(MIN_EXTENT_M - (hi - lo), 0.0) * 0.5
        return lo - grow, hi + grow

    def update(self, lo, hi) -> Camera:
        if not self.follow or not np.all(np.asarray(hi) >= np.asarray(lo)):
            return self.camera
        lo, hi = self.framed_box(lo, hi)
        goal = self.base.copy().fit(lo, hi, aspect=self.aspect, margin=MARGIN, set_clip=False)
        goal_dist = float(np.linalg.norm(goal.eye - goal.target))
        if self._target is None:
            self._target, self._dist = goal.target.copy(), goal_dist
        else:
            self._target = self._target + SMOOTHING * (goal.target - self._target)
            self._dist = self._dist + SMOOTHING * (goal_dist - self._dist)
        cam = self.camera
        self._dist = max(self._dist, cam.fit_distance(lo, hi, self._target, self.aspect, MARGIN))
        _, _, back = self.base.basis()
        cam.target = self._target.copy()
        cam.eye = self._target + back * self._dist
        # clip planes around the framed box (reversed Z keeps depth precise with a small near plane)
        radius = 0.5 * float(np.linalg.norm(hi - lo))
        cam.near = max(1e-3 * self._dist, min(0.5 * (self._dist - radius), 0.1 * self._dist))
        cam.far = max(10.0 * (self._dist + radius), cam.near * 10.0)
        return cam
