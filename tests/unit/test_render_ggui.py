"""Headless GGUI frames: size, visibility, motion, and agreement with the Taichi rasteriser (silhouettes,
Lambert colours, particle sizes). Skipped only where the Vulkan probe fails."""

from __future__ import annotations

import numpy as np
import pytest

from render.camera import Camera
from render.ggui import vulkan_status
from render.primitives import box_mesh
from render.raster import RasterRenderer
from render.scene_data import Lighting, MeshPart, disc_outline
from rigid.quat import quat_from_axis_angle, quat_to_matrix

W, H = 320, 240


@pytest.fixture(scope="module")
def renderers(taichi_runtime):
    from render.ggui import GGUIRenderer

    ok, why = vulkan_status()  # probed once per process, in a subprocess
    if not ok:
        pytest.skip(f"GGUI needs Vulkan, unavailable here: {why}")
    g = GGUIRenderer(W, H)
    r = RasterRenderer(W, H)
    yield g, r
    g.release()
    r.release()


def _mask(img, scene):
    return np.any(img != np.rint(scene.lighting.background * 255).astype(np.uint8), axis=-1)


def _iou(a, b) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def _erode(m):
    e = m.copy()
    e[1:] &= m[:-1]
    e[:-1] &= m[1:]
    e[:, 1:] &= m[:, :-1]
    e[:, :-1] &= m[:, 1:]
    return e


def _box_scene(scene, pose_x, pose_q):
    v, f = box_mesh([0.1, 0.08, 0.06])
    scene.lighting = Lighting()
    scene.set_surfaces([MeshPart(v, f, 0, colors=(0.8, 0.5, 0.3))])
    scene.set_poses([pose_x], [pose_q], [[0, 0, 0]])
    scene.update()
    return v


CAM = Camera(eye=[0.45, 0.35, 0.7], target=[0.0, 0.0, 0.0], near=0.05, far=10.0)


def test_ggui_box_visible_and_moves(scene, renderers):
    g, _ = renderers
    scene.set_particles(np.zeros((0, 3)), 1.0)
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
    frames = []
    for x, q in (([0, 0, 0], [1, 0, 0, 0]), ([0.04, 0.02, 0.0], quat_from_axis_angle([0, 1, 0.3], 0.6))):
        v = _box_scene(scene, x, q)
        img = g.render(scene, CAM)
        assert img.shape == (H, W, 3) and img.dtype == np.uint8
        m = _mask(img, scene)
        px, _, _ = CAM.project(v @ quat_to_matrix(np.asarray(q, float)).T + x, W, H)
        x0, y0 = np.floor(px.min(0)).astype(int)
        x1, y1 = np.ceil(px.max(0)).astype(int)
        assert m[y0:y1, x0:x1].mean() > 0.5
        outside = m.copy()
        outside[y0 - 1 : y1 + 1, x0 - 1 : x1 + 1] = False
        assert not outside.any()
        frames.append(img)
    assert np.any(frames[0] != frames[1], axis=-1).mean() > 0.02


@pytest.mark.parametrize("pose", [0, 1])
def test_ggui_agrees_with_raster(scene, renderers, pose):
    """Same frame (box, particles, crack-disc outline): silhouettes IoU > 0.9, interior colours within 2 levels."""
    g, r = renderers
    q = [1, 0, 0, 0] if pose == 0 else quat_from_axis_angle([1, 1, 0], 0.8)
    _box_scene(scene, [0, 0.02 * pose, 0], q)
    scene.set_particles([[0.18, 0.0, 0.05], [-0.15, 0.1, -0.1]], [0.03, 0.05],
                        colors=[[0.2, 0.6, 0.9], [0.9, 0.9, 0.3]])
    a, b = disc_outline([0.0, -0.1, 0.0], [0, 1, 0], 0.15, 32)
    scene.set_lines(a, b, colors=(1.0, 0.2, 0.2), width=2)
    ig = g.render(scene, CAM)
    ir = r.render(scene, CAM)
    mg, mr = _mask(ig, scene), _mask(ir, scene)
    assert _iou(mg, mr) > 0.9
    inner = _erode(_erode(mg & mr))
    d = np.abs(ig.astype(int) - ir.astype(int)).max(-1)[inner]
    assert np.median(d) <= 1 and np.percentile(d, 99) <= 4


@pytest.mark.parametrize("angle_deg,two_sided", [(0.0, False), (50.0, False), (110.0, False), (110.0, True)])
def test_ggui_lambert_matches_raster(scene, renderers, angle_deg, two_sided):
    """GGUI's shading of a face lit at angle a equals the rasteriser's c (ambient + light max(cos a, 0))
    (|cos a| for two-sided faces)."""
    g, r = renderers
    a = np.radians(angle_deg)
    cam = Camera(eye=[0, 0, 1.0], target=[0, 0, 0], near=0.05, far=10.0)
    scene.lighting = Lighting(light_dir=[np.sin(a), 0, np.cos(a)], ambient=[0.2] * 3, light_color=[0.7] * 3,
                              two_sided=two_sided)
    quad = np.array([[-0.3, -0.3, 0], [0.3, -0.3, 0], [0.3, 0.3, 0], [-0.3, 0.3, 0]])
    c = np.array([0.8, 0.4, 0.2])
    scene.set_surfaces([MeshPart(quad, np.array([[0, 1, 2], [0, 2, 3]]), -1, colors=c)])
    scene.set_particles(np.zeros((0, 3)), 1.0)
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
    cos = abs(np.cos(a)) if two_sided else max(np.cos(a), 0.0)
    want = c * (0.2 + 0.7 * cos) * 255
    for img in (g.render(scene, cam), r.render(scene, cam)):
        assert np.abs(img[H // 2, W // 2] - want).max() <= 1.0


def test_ggui_particle_size(scene, renderers):
    """Particles have their projected radius in GGUI too (radii are scaled by H / W, see render/ggui.py)."""
    g, r = renderers
    cam = Camera(eye=[0, 0, 1.0], target=[0, 0, 0], near=0.05, far=10.0)
    scene.lighting = Lighting(light_dir=[0, 0, 1])
    scene.set_surfaces([])
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
    rad = 0.1
    scene.set_particles([[0, 0, 0]], rad, colors=(0.9, 0.9, 0.9))
    focal = 1.0 / np.tan(np.radians(22.5)) * H / 2
    for img in (g.render(scene, cam), r.render(scene, cam)):
        assert abs(np.sqrt(_mask(img, scene).sum() / np.pi) - focal * rad / 1.0) < 1.5
