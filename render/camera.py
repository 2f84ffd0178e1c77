"""A pinhole camera whose matrices are GGUI's, plus the orbit / pan / zoom / fit maths of a viewer.

Conventions (docs/notes_render.md), identical to `ti.ui.Camera` in Taichi 1.7.4:
  * row vectors: `clip = [p, 1] @ V @ P` with `V = view_matrix()` and `P = projection_matrix(W / H)`;
  * view space is right-handed, the camera looks down -z, `w_clip = -z_view` (distance along the view axis);
  * reversed Z: `z_ndc = z_clip / w_clip` is 1 on the near plane and 0 on the far plane;
  * NDC y points up; pixel (column x, row y) has its centre at `x + 0.5, y + 0.5`, row 0 at the top:
    `x_px = (ndc_x + 1) W / 2`, `y_px = (1 - ndc_y) H / 2`.
The vertical field of view is in degrees, as GGUI's `fov`. Everything here is numpy (float64) and
allocates no Taichi data, so a viewer can call it every mouse event.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import ConfigError

MIN_PITCH_MARGIN_DEG = 1.0  # deg: orbit keeps the view direction this far from the up axis


def _unit(v: np.ndarray, what: str) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64).reshape(3)
    n = float(np.linalg.norm(v))
    if not np.isfinite(n) or n == 0.0:
        raise ConfigError(f"camera.{what}", v.tolist(), "a finite non-zero 3-vector")
    return v / n


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues rotation of v about the unit vector axis by angle (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1.0 - c)


def box_corners(lo, hi) -> np.ndarray:
    """(8, 3): the corners of the axis-aligned box [lo, hi]."""
    lo = np.asarray(lo, dtype=np.float64).reshape(3)
    hi = np.asarray(hi, dtype=np.float64).reshape(3)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


@dataclass
class Camera:
    """Perspective camera: eye, target, up (world, metres), vertical fov (deg), near/far (m)."""

    eye: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.3, 1.0]))
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    fov_deg: float = 45.0
    near: float = 0.01
    far: float = 100.0

    def __post_init__(self) -> None:
        self.eye = np.asarray(self.eye, dtype=np.float64).reshape(3).copy()
        self.target = np.asarray(self.target, dtype=np.float64).reshape(3).copy()
        self.up = np.asarray(self.up, dtype=np.float64).reshape(3).copy()
        self.validate()

    def validate(self) -> None:
        """Raise ConfigError for a camera that cannot produce an image."""
        if not (0.0 < self.fov_deg < 180.0):
            raise ConfigError("camera.fov_deg", self.fov_deg, "0 < fov < 180 degrees")
        if not (0.0 < self.near < self.far) or not np.isfinite(self.far):
            raise ConfigError("camera.near/far", (self.near, self.far), "0 < near < far < inf (m)")
        for name in ("eye", "target", "up"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ConfigError(f"camera.{name}", getattr(self, name).tolist(), "finite coordinates (m)")
        d = self.eye - self.target
        if np.linalg.norm(d) == 0.0:
            raise ConfigError("camera.eye", self.eye.tolist(), "a point different from camera.target")
        if np.linalg.norm(np.cross(_unit(self.up, "up"), d)) <= 1e-12 * np.linalg.norm(d):
            raise ConfigError("camera.up", self.up.tolist(), "a direction not parallel to eye - target")

    def copy(self) -> Camera:
        return Camera(self.eye.copy(), self.target.copy(), self.up.copy(), self.fov_deg, self.near, self.far)

    # ---- frame and matrices -------------------------------------------------------------------
    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, back) unit vectors of the view frame in world coordinates (back = eye - target)."""
        back = _unit(self.eye - self.target, "eye - target")
        right = _unit(np.cross(self.up, back), "up x (eye - target)")
        up = np.cross(back, right)
        return right, up, back

    @property
    def distance(self) -> float:
        """m: eye-to-target distance."""
        return float(np.linalg.norm(self.eye - self.target))

    def view_matrix(self) -> np.ndarray:
        """(4, 4) world -> view, row-vector convention: `[p, 1] @ V` (GGUI's get_view_matrix())."""
        r, u, b = self.basis()
        v = np.eye(4)
        v[:3, 0], v[:3, 1], v[:3, 2] = r, u, b
        v[3, :3] = [-r @ self.eye, -u @ self.eye, -b @ self.eye]
        return v

    def projection_matrix(self, aspect: float) -> np.ndarray:
        """(4, 4) view -> clip, reversed Z, row vectors (GGUI's get_projection_matrix(aspect = W / H))."""
        if not aspect > 0.0:
            raise ConfigError("camera aspect", aspect, "width / height > 0")
        f = 1.0 / np.tan(np.radians(self.fov_deg) / 2.0)
        n, fa = self.near, self.far
        p = np.zeros((4, 4))
        p[0, 0] = f / aspect
        p[1, 1] = f
        p[2, 2] = n / (fa - n)  # z_clip = z_view n/(f-n) + n f/(f-n); w_clip = -z_view
        p[2, 3] = -1.0
        p[3, 2] = n * fa / (fa - n)
        return p

    def view_projection(self, aspect: float) -> np.ndarray:
        """(4, 4) `V @ P`: world -> clip for row vectors."""
        return self.view_matrix() @ self.projection_matrix(aspect)

    # ---- projection and picking ------------------------------------------------------------------
    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates (N, 2) (x right, y down, row 0 at the top, continuous: a pixel's centre is
        at +0.5), reversed-Z NDC depth (N,) and view distance w (N,) of world points (N, 3)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        clip = np.c_[p, np.ones(len(p))] @ self.view_projection(width / height)
        w = clip[:, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            ndc = clip[:, :3] / w[:, None]
        px = np.stack([(ndc[:, 0] + 1.0) * 0.5 * width, (1.0 - ndc[:, 1]) * 0.5 * height], 1)
        return px, ndc[:, 2], w

    def ray(self, x_px: float, y_px: float, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World ray (origin, unit direction) through the continuous pixel position (x_px, y_px), for
        picking: pass the cursor position in pixels from the top-left corner."""
        ndc_x = 2.0 * x_px / width - 1.0
        ndc_y = 1.0 - 2.0 * y_px / height
        inv = np.linalg.inv(self.view_projection(width / height))
        p_near = np.array([ndc_x, ndc_y, 1.0, 1.0]) @ inv  # reversed Z: z_ndc = 1 on the near plane
        p_near = p_near[:3] / p_near[3]
        return self.eye.copy(), _unit(p_near - self.eye, "ray")

    # ---- viewer motions (pure maths) ---------------------------------------------------------------
    def orbit(self, yaw: float, pitch: float) -> Camera:
        """Turn the eye around the target: yaw (rad) about the up axis, pitch (rad, > 0 raises the eye)
        about the right axis; the elevation stays MIN_PITCH_MARGIN_DEG away from the poles."""
        up = _unit(self.up, "up")
        off = _rotate(self.eye - self.target, up, yaw)
        dist = np.linalg.norm(off)
        elev = np.arcsin(np.clip(off @ up / dist, -1.0, 1.0))
        lim = np.radians(90.0 - MIN_PITCH_MARGIN_DEG)
        new_elev = np.clip(elev + pitch, -lim, lim)
        right = _unit(np.cross(up, off), "orbit axis")
        off = _rotate(off, right, -(new_elev - elev))  # rotating about up x off by -a raises the eye by a
        self.eye = self.target + off
        return self

    def pan(self, dx_px: float, dy_px: float, height: int) -> Camera:
        """Drag the scene by (dx, dy) pixels (y down): eye and target move in the view plane so that a
        point at the target's depth follows the cursor."""
        r, u, _ = self.basis()
        scale = 2.0 * self.distance * np.tan(np.radians(self.fov_deg) / 2.0) / height  # m per pixel
        shift = (-dx_px * r + dy_px * u) * scale
        self.eye = self.eye + shift
        self.target = self.target + shift
        return self

    def zoom(self, factor: float) -> Camera:
        """Move the eye towards the target: factor > 1 zooms in (distance / factor); the eye stays
        beyond twice the near distance."""
        if not factor > 0.0:
            raise ConfigError("camera zoom factor", factor, "> 0")
        d = self.eye - self.target
        dist = max(np.linalg.norm(d) / factor, 2.0 * self.near)
        self.eye = self.target + d / np.linalg.norm(d) * dist
        return self

    def fit(self, lo, hi, aspect: float = 4.0 / 3.0, margin: float = 1.1, set_clip: bool = True) -> Camera:
        """Frame the axis-aligned box [lo, hi] (m): keep the view direction, aim at the box centre and
        step back to the smallest distance at which all eight corners project inside the image shrunk
        by `margin` (closed form per corner: d >= z_back + margin max(|x| sx, |y| sy), with (x, y, z_back)
        the corner in the view basis about the centre and sx, sy the projection scales). With set_clip
        the near plane sits at half the distance of the nearest corner (at least 1e-3 x distance; reversed
        Z keeps the depth precise) and the far plane at least twice the farthest corner."""
        lo = np.asarray(lo, dtype=np.float64).reshape(3)
        hi = np.asarray(hi, dtype=np.float64).reshape(3)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi >= lo)):
            raise ConfigError("camera.fit bounds", (lo.tolist(), hi.tolist()), "finite lo <= hi (m)")
        if not margin >= 1.0:
            raise ConfigError("camera.fit margin", margin, ">= 1")
        centre = 0.5 * (lo + hi)
        pad = 1e-6 * max(float(np.linalg.norm(hi - lo)), 1.0)  # a point still gets a finite distance
        corners = box_corners(lo - pad, hi + pad) - centre
        b = self.basis()[2]  # the current view direction is kept
        zb = corners @ b
        dist = max(self.fit_distance(lo - pad, hi + pad, centre, aspect, margin), float(np.max(zb)) + pad)
        self.target = centre
        self.eye = centre + b * dist
        if set_clip:
            self.near = max(0.5 * (dist - float(np.max(zb))), 1e-3 * dist)
            self.far = max(self.far, 2.0 * (dist - float(np.min(zb))))
        return self

    def fit_distance(self, lo, hi, target, aspect: float, margin: float = 1.0) -> float:
        """Smallest eye distance from `target` along the current view axis at which every corner of
        the box [lo, hi] projects inside the image shrunk by `margin`: per corner (x, y, z_back) in the
        view basis about the target, d >= z_back + margin max(|x| sx, |y| sy)."""
        corners = box_corners(lo, hi) - np.asarray(target, dtype=np.float64)
        r, u, b = self.basis()
        proj = self.projection_matrix(aspect)
        x, y, zb = corners @ r, corners @ u, corners @ b
        return float(np.max(zb + margin * np.maximum(np.abs(x) * proj[0, 0], np.abs(y) * proj[1, 1])))

    # ---- GGUI ------------------------------------------------------------------------------------
    def to_ggui(self, cam) -> None:
        """Copy this camera into a `ti.ui.Camera` (position, lookat, up, fov, near, far)."""
        cam.position(*self.eye.tolist())
        cam.lookat(*self.target.tolist())
        cam.up(*self.up.tolist())
        cam.fov(float(self.fov_deg))
        cam.z_near(float(self.near))
        cam.z_far(float(self.far))
