"""Camera: GGUI's matrices, the projection of known points, picking rays and the viewer motions."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from render.camera import MIN_PITCH_MARGIN_DEG, Camera

CAMERAS = [
    dict(eye=[1.0, 2.0, 3.0], target=[0.0, 0.0, 0.0], fov_deg=45.0, near=0.1, far=100.0),
    dict(eye=[-0.4, 0.3, 0.2], target=[0.1, 0.05, -0.2], fov_deg=60.0, near=0.01, far=10.0),
    dict(eye=[0.0, 5.0, 0.1], target=[0.0, 0.0, 0.0], fov_deg=30.0, near=0.5, far=1000.0),
]


def _ggui_camera(c: Camera):
    import taichi as ti

    cam = ti.ui.Camera()
    c.to_ggui(cam)
    return cam


@pytest.mark.parametrize("spec", CAMERAS)
@pytest.mark.parametrize("aspect", [4.0 / 3.0, 16.0 / 9.0, 0.75])
def test_matrices_match_ggui(taichi_runtime, spec, aspect):
    """view_matrix / projection_matrix equal ti.ui.Camera's (computed by GGUI in f32: 1e-5 relative)."""
    c = Camera(**spec)
    g = _ggui_camera(c)
    v_ggui = np.array(g.get_view_matrix(), dtype=np.float64)
    p_ggui = np.array(g.get_projection_matrix(aspect), dtype=np.float64)
    scale_v = max(1.0, float(np.abs(c.view_matrix()).max()))
    assert np.allclose(c.view_matrix(), v_ggui, rtol=1e-5, atol=1e-5 * scale_v)
    assert np.allclose(c.projection_matrix(aspect), p_ggui, rtol=1e-5, atol=1e-6)


def test_projection_documented_values():
    """The documented formula (reversed Z, row vectors) for eye (1, 2, 3), fov 45, near 0.1, far 100, 4:3."""
    c = Camera(**CAMERAS[0])
    p = c.projection_matrix(4.0 / 3.0)
    f = 1.0 / np.tan(np.radians(22.5))
    expected = np.array([[f * 0.75, 0, 0, 0], [0, f, 0, 0], [0, 0, 0.1 / 99.9, -1.0], [0, 0, 10.0 / 99.9, 0]])
    assert np.allclose(p, expected, rtol=1e-12, atol=1e-15)
    v = c.view_matrix()
    assert np.allclose(v[:3, :3].T @ v[:3, :3], np.eye(3), atol=1e-12)  # a rotation
    assert np.allclose(np.r_[c.eye, 1.0] @ v, [0, 0, 0, 1], atol=1e-12)  # the eye is the view origin
    assert np.allclose(v[:3, 2], np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0), atol=1e-12)  # +z_view = backwards


@pytest.mark.parametrize("spec", CAMERAS)
def test_project_known_points(spec):
    """On the view axis at distance d: image centre, z_ndc = n (f - d) / (d (f - n)); at the edge of the
    vertical / horizontal field of view: the top row / the right column."""
    c = Camera(**spec)
    w_px, h_px = 320, 200
    r, u, b = c.basis()
    d = 0.5 * (c.near + c.far) if c.far < 50 else 3.0
    t = np.tan(np.radians(c.fov_deg) / 2.0)
    centre = c.eye - b * d
    pts = np.array([centre, centre + u * d * t, centre + r * d * t * w_px / h_px, centre - u * d * t * 0.5])
    px, z, w = c.project(pts, w_px, h_px)
    assert np.allclose(px[0], [w_px / 2, h_px / 2], atol=1e-9)
    assert np.isclose(z[0], c.near * (c.far - d) / (d * (c.far - c.near)), rtol=1e-12)
    assert np.allclose(w, d, rtol=1e-12)
    assert np.allclose(px[1], [w_px / 2, 0.0], atol=1e-9)  # row 0 is the top
    assert np.allclose(px[2], [w_px, h_px / 2], atol=1e-9)
    assert np.allclose(px[3], [w_px / 2, 0.75 * h_px], atol=1e-9)
    # near plane -> 1, far plane -> 0 (reversed Z)
    _, zz, _ = c.project(np.array([c.eye - b * c.near, c.eye - b * c.far]), w_px, h_px)
    assert np.allclose(zz, [1.0, 0.0], atol=1e-12)


def test_project_matches_ggui_matrices(taichi_runtime):
    """Camera.project agrees with clip = [p, 1] @ V @ P using ti.ui.Camera's own matrices."""
    c = Camera(**CAMERAS[1])
    g = _ggui_camera(c)
    w_px, h_px = 640, 480
    vp = np.array(g.get_view_matrix(), np.float64) @ np.array(g.get_projection_matrix(w_px / h_px), np.float64)
    rng = np.random.default_rng(1)
    pts = c.target + rng.uniform(-0.1, 0.1, (20, 3))
    clip = np.c_[pts, np.ones(len(pts))] @ vp
    ndc = clip[:, :3] / clip[:, 3:]
    px_ggui = np.stack([(ndc[:, 0] + 1) * 0.5 * w_px, (1 - ndc[:, 1]) * 0.5 * h_px], 1)
    px, z, _ = c.project(pts, w_px, h_px)
    assert np.allclose(px, px_ggui, atol=1e-3)  # px; GGUI's matrices are f32
    assert np.allclose(z, ndc[:, 2], atol=1e-5)


def test_ray_goes_through_projected_point():
    c = Camera(**CAMERAS[1])
    p = c.target + np.array([0.03, -0.02, 0.05])
    (px,), _, _ = c.project(p[None], 400, 300)
    o, d = c.ray(px[0], px[1], 400, 300)
    assert np.isclose(np.linalg.norm(d), 1.0)
    along = (p - o) @ d
    assert np.linalg.norm(o + along * d - p) < 1e-10


def test_orbit_pan_zoom():
    c = Camera(eye=[0.0, 0.2, 1.0], target=[0.1, 0.0, 0.0])
    dist, target = c.distance, c.target.copy()
    c.orbit(0.7, 0.3)
    assert np.isclose(c.distance, dist) and np.allclose(c.target, target)
    c2 = c.copy().orbit(2.0 * np.pi, 0.0)
    assert np.allclose(c2.eye, c.eye, atol=1e-12)  # a full turn about up
    # pitch raises the eye and stops short of the pole
    h0 = (c.eye - c.target) @ c.up
    c.orbit(0.0, 0.1)
    assert (c.eye - c.target) @ c.up > h0
    c.orbit(0.0, 10.0)
    elev = np.degrees(np.arcsin((c.eye - c.target) @ c.up / c.distance))
    assert np.isclose(elev, 90.0 - MIN_PITCH_MARGIN_DEG)
    # pan: the old target follows the cursor by (dx, dy) pixels
    c = Camera(eye=[0.0, 0.2, 1.0], target=[0.1, 0.0, 0.0])
    old = c.target.copy()
    c.pan(30.0, -12.0, 480)
    (px,), _, _ = c.project(old[None], 640, 480)
    assert np.allclose(px, [320 + 30.0, 240 - 12.0], atol=1e-9)
    # zoom
    d0 = c.distance
    c.zoom(2.0)
    assert np.isclose(c.distance, d0 / 2.0)
    c.zoom(1e9)
    assert np.isclose(c.distance, 2.0 * c.near)


@pytest.mark.parametrize("aspect", [4.0 / 3.0, 0.5])
def test_fit_frames_box(aspect):
    """After fit every corner is inside the image, and the tightest one touches the margin."""
    lo, hi = np.array([-0.3, 0.0, -0.1]), np.array([0.5, 0.2, 0.4])
    c = Camera(eye=[2.0, 1.0, 3.0], target=[0.0, 0.0, 0.0]).fit(lo, hi, aspect=aspect, margin=1.25)
    h_px = 400
    w_px = int(round(h_px * aspect))
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    px, z, w = c.project(corners, w_px, h_px)
    ndc = np.c_[px[:, 0] / w_px * 2 - 1, 1 - px[:, 1] / h_px * 2]
    assert np.all(w > c.near) and np.all(w < c.far) and np.all((z > 0) & (z < 1))
    assert np.isclose(np.abs(ndc).max(), 1.0 / 1.25, rtol=1e-3)
    assert np.allclose(c.target, 0.5 * (lo + hi))
    assert np.allclose((c.eye - c.target) / c.distance, np.array([2.0, 1.0, 3.0]) / np.sqrt(14.0))


def test_invalid_cameras():
    with pytest.raises(ConfigError, match="fov"):
        Camera(fov_deg=0.0)
    with pytest.raises(ConfigError, match="near"):
        Camera(near=1.0, far=0.5)
    with pytest.raises(ConfigError, match="up"):
        Camera(eye=[0, 1, 0], target=[0, 0, 0], up=[0, 2, 0])
    with pytest.raises(ConfigError, match="eye"):
        Camera(eye=[0, 0, 0], target=[0, 0, 0])
