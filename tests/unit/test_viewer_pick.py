"""Viewer picking (render/pick.py) against a box whose answers are known in closed form, the
`--script` grammar (viewer/script.py), and the overlay geometry of kernels and crack discs
(viewer/overlay.py). Pure numpy: no window, no Taichi fields."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from render.camera import Camera
from render.pick import cursor_pixels, pick, ray_cast, ray_triangles
from render.primitives import box_mesh
from viewer.script import parse_script

CENTRE = np.array([1.0, 0.2, -0.5])
HALF = np.array([0.1, 0.2, 0.3])


@pytest.fixture(scope="module")
def box():
    v, f = box_mesh(HALF, CENTRE)
    tris = v[f]
    bodies = np.full(len(f), 7)
    return tris, bodies


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_ray_hits_each_face_at_the_right_point_and_normal(box, axis, sign):
    """A ray aimed at the box from outside along -sign e_axis hits the face x_axis = c + sign h at the
    ray's transverse offset, with the outward normal sign e_axis."""
    tris, bodies = box
    offset = np.array([0.03, -0.05, 0.07]) * (np.arange(3) != axis)  # transverse, inside the face
    origin = CENTRE + offset
    origin[axis] += sign * 5.0
    d = np.zeros(3)
    d[axis] = -sign
    hit = ray_cast(origin, d, tris, bodies)
    expect = CENTRE + offset
    expect[axis] = CENTRE[axis] + sign * HALF[axis]
    assert hit is not None and hit.body == 7
    np.testing.assert_allclose(hit.point, expect, atol=1e-12)
    np.testing.assert_allclose(hit.normal, -d, atol=1e-12)
    assert hit.distance == pytest.approx(5.0 - HALF[axis], abs=1e-12)


def test_oblique_ray_and_nearest_of_two_hits(box):
    """An oblique ray enters through the +z face (the nearer of its two hits) at the analytic point."""
    tris, bodies = box
    target = CENTRE + np.array([0.02, 0.05, HALF[2]])
    d = np.array([0.3, -0.2, -1.0])
    d /= np.linalg.norm(d)
    origin = target - 2.0 * d
    t = ray_triangles(origin, d, tris)
    assert np.sum(np.isfinite(t)) >= 2  # enters and leaves (a shared edge may count twice)
    hit = ray_cast(origin, d, tris, bodies)
    np.testing.assert_allclose(hit.point, target, atol=1e-12)
    np.testing.assert_allclose(hit.normal, [0.0, 0.0, 1.0], atol=1e-12)
    assert hit.distance == pytest.approx(2.0, abs=1e-12)


def test_misses_and_hits_behind_the_origin_are_ignored(box):
    tris, bodies = box
    assert ray_cast(CENTRE + [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], tris, bodies) is None  # passes above
    assert ray_cast(CENTRE + [0.0, 0.0, 2.0], [0.0, 0.0, 1.0], tris, bodies) is None  # box behind
    inside = ray_cast(CENTRE, [1.0, 0.0, 0.0], tris, bodies)  # from inside: the +x face, facing the origin
    np.testing.assert_allclose(inside.point, CENTRE + [HALF[0], 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(inside.normal, [-1.0, 0.0, 0.0], atol=1e-12)


def test_pick_through_the_camera_finds_the_projected_point(box):
    """Project a point of the +z face to a pixel; picking that pixel returns the point (the camera ray
    inverts GGUI's projection) and the face normal; a pixel outside the box picks nothing."""
    tris, bodies = box
    cam = Camera(eye=CENTRE + [0.4, 0.5, 1.5], target=CENTRE, fov_deg=40.0)
    W, H = 640, 480
    p = CENTRE + np.array([-0.04, 0.1, HALF[2]])
    px, _, _ = cam.project(p, W, H)
    hit = pick(tris, bodies, cam, px[0, 0], px[0, 1], W, H)
    np.testing.assert_allclose(hit.point, p, atol=1e-9)
    np.testing.assert_allclose(hit.normal, [0.0, 0.0, 1.0], atol=1e-12)
    assert pick(tris, bodies, cam, 2.0, 2.0, W, H) is None


def test_cursor_pixels_from_ggui_cursor():
    """GGUI's cursor y runs from the bottom; pixels run from the top."""
    assert cursor_pixels((0.25, 0.75), 800, 600) == (200.0, 150.0)
    assert cursor_pixels((0.0, 1.0), 800, 600) == (0.0, 0.0)


def test_script_grammar():
    acts = parse_script("strike@10,toggle@12:particles, shot@20:/tmp/a b/x.png,set@3:speed=2.5,ball@4:10x20,hover@5")
    assert [(a.name, a.frame, a.arg) for a in acts] == [
        ("strike", 10, ""), ("toggle", 12, "particles"), ("shot", 20, "/tmp/a b/x.png"), ("set", 3, "speed=2.5"),
        ("ball", 4, "10x20"), ("hover", 5, "")]
    assert parse_script("") == [] and parse_script(None) == []
    for bad in ("explode@3", "strike", "strike@x", "toggle@1:wings", "set@1:speed", "set@1:mass=2", "shot@2",
                "colour@1:pink", "zoom@1:-2", "ball@1:12"):
        with pytest.raises(ConfigError):
            parse_script(bad)


def test_kernel_ellipses_lie_on_the_support_surface():
    """Every point of the drawn kernel loops satisfies |G R^T (x - c)| = 1 (the support boundary of Eq. 4
    for a body rotated by R), and the loops reach the three semi-axes."""
    from rigid.quat import quat_from_axis_angle, quat_to_matrix
    from viewer.overlay import ellipsoid_loops

    Q = quat_to_matrix(quat_from_axis_angle([0.2, 1.0, -0.4], 0.7))  # kernel axes in the body frame
    h = np.array([0.03, 0.01, 0.02])
    G = Q @ np.diag(1.0 / h) @ Q.T
    R = quat_to_matrix(quat_from_axis_angle([1.0, 0.0, 0.3], -1.1))  # body rotation
    c = np.array([0.5, -0.2, 0.1])
    a, b = ellipsoid_loops(c, G, R, segments=64)
    for p in (a, b):
        q = np.linalg.norm((p - c) @ R @ G.T, axis=1)
        np.testing.assert_allclose(q, 1.0, atol=1e-12)
    r = np.linalg.norm(a - c, axis=1)
    assert r.max() == pytest.approx(h.max(), rel=1e-3) and r.min() == pytest.approx(h.min(), rel=1e-3)


def test_half_disc_outline():
    """A half-disc outline stays in its plane, within the radius, on its side (the diameter closes it)."""
    from viewer.overlay import half_disc

    p, n, s = np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.0, 1.0]), np.array([1.0, 1.0, 0.0])
    a, b = half_disc(p, n, 0.05, s, segments=40)
    pts = np.r_[a, b] - p
    np.testing.assert_allclose(pts @ n, 0.0, atol=1e-15)
    assert np.all(np.linalg.norm(pts, axis=1) <= 0.05 * (1 + 1e-12))
    assert np.all(pts @ (s / np.linalg.norm(s)) >= -1e-12)
    full_a, _ = half_disc(p, n, 0.05, None, segments=40)
    np.testing.assert_allclose(np.linalg.norm(full_a - p, axis=1), 0.05)
