"""The studio look of headless frames (render/raster.py): the key light's shadow lands where the light
ray through the caster meets the floor and is darker by the key light's share; no shadow from a light
below the floor; see-through surfaces blend over what is behind them; frames repeat exactly; 'auto'
draws with the rasteriser."""

from __future__ import annotations

import numpy as np
import pytest

from render.camera import Camera
from render.primitives import box_mesh, ground_quad, sphere_mesh
from render.raster import RasterRenderer
from render.scene_data import Lighting, MeshPart, RenderScene, disc_outline
from render.select import make_renderer

W, H = 200, 200
FLOOR = (0.6, 0.6, 0.6)
BALL = (0.9, 0.1, 0.1)
CENTRE = np.array([0.0, 0.25, 0.0])  # m: the ball's centre, 0.25 m above the floor at y = 0
RADIUS = 0.06  # m


@pytest.fixture(scope="module")
def raster(taichi_runtime):
    r = RasterRenderer(W, H)
    yield r
    r.release()


def _top_camera() -> Camera:
    """Looking straight down at the floor: a figure on the floor keeps its centroid in the image."""
    return Camera(eye=[0.0, 1.5, 0.0], target=[0.0, 0.0, 0.0], up=[0.0, 0.0, -1.0], fov_deg=40.0, near=0.1, far=10.0)


def _ball_over_floor(scene: RenderScene, light_dir) -> Lighting:
    lt = Lighting.studio()
    lt.light_dir = np.asarray(light_dir, float) / np.linalg.norm(light_dir)
    lt.antialias = False
    lt.specular = False  # the floor's value then follows the diffuse formula exactly
    scene.lighting = lt
    vb, fb = sphere_mesh(RADIUS)
    vg, fg = ground_quad(0.0, 1.0)
    scene.set_surfaces([MeshPart(vg, fg, -1, colors=FLOOR), MeshPart(vb, fb, 0, colors=BALL)])
    scene.set_poses([CENTRE], [[1, 0, 0, 0]], [[0, 0, 0]])
    scene.set_particles(np.zeros((0, 3)), 1.0)
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
    scene.update()
    return lt


def _floor_pixels(img: np.ndarray) -> np.ndarray:
    """Mask of pixels showing the grey floor (not the red ball): red and green within a few levels."""
    r, g = img[..., 0].astype(int), img[..., 1].astype(int)
    return abs(r - g) <= 3


@pytest.mark.parametrize("light_dir", [[0.8, 1.0, 0.0], [0.6, 1.0, 0.5], [-0.5, 1.0, 0.7]])
def test_shadow_lands_on_the_light_ray(scene, raster, light_dir):
    """The ball's shadow (clear of the ball in the image) is centred where the ray from the ball's
    centre towards the light meets the floor (to 1.5 px), and the shadowed floor is darker than the
    lit floor by at least 80 % of the key light's term c (l . n) (the filter softens only the rim)."""
    lt = _ball_over_floor(scene, light_dir)
    cam = _top_camera()
    img = raster.render(scene, cam)
    l = lt.light_dir
    ndf = max(float(lt.fill_dir[1]), 0.0)
    lit = np.asarray(FLOOR) * (lt.ambient + lt.fill_color * ndf + lt.light_color * l[1]) * 255
    dark = np.asarray(FLOOR) * (lt.ambient + lt.fill_color * ndf) * 255
    floor = _floor_pixels(img)
    value = img[..., 1].astype(float)
    shadow = floor & (value < 0.5 * (lit[1] + dark[1]))
    assert shadow.sum() > 50
    ys, xs = np.nonzero(shadow)
    foot = CENTRE - CENTRE[1] / l[1] * l
    (px, py), _, _ = (a[0] for a in cam.project(foot[None], W, H))
    assert abs(xs.mean() + 0.5 - px) < 1.5 and abs(ys.mean() + 0.5 - py) < 1.5
    core = np.median(value[shadow])
    lit_px = np.median(value[floor & ~shadow])
    assert abs(lit_px - lit[1]) <= 1.5
    assert lit_px - core >= 0.8 * (lit[1] - dark[1])


def test_no_shadow_from_a_light_below_the_floor(scene, raster):
    """A key light under the floor lights nothing on its top face and casts nothing on it."""
    _ball_over_floor(scene, [0.3, -1.0, 0.2])
    img = raster.render(scene, _top_camera())
    v = img[..., 1][_floor_pixels(img)].astype(int)
    assert v.max() - v.min() <= 1


def test_see_through_surface_blends(scene, raster):
    """A pane of opacity a in front of an opaque box shows a c_pane + (1 - a) c_box (plain lighting,
    both faces lit head-on), and the box alone where the pane does not cover it."""
    cam = Camera(eye=[0, 0, 1.0], target=[0, 0, 0], near=0.05, far=10.0)
    scene.lighting = Lighting(light_dir=[0, 0, 1], ambient=[0.25] * 3, light_color=[0.75] * 3)
    vb, fb = box_mesh([0.2, 0.2, 0.05], center=[0.0, 0.0, -0.1])
    vp, fp = box_mesh([0.05, 0.05, 0.01], center=[0.0, 0.0, 0.1])
    a = 0.4
    scene.set_surfaces([MeshPart(vb, fb, -1, colors=(0.2, 0.2, 0.9)),
                        MeshPart(vp, fp, -1, colors=(0.9, 0.9, 0.1), opacity=a)])
    scene.set_particles(np.zeros((0, 3)), 1.0)
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
    scene.update()
    img = raster.render(scene, cam).astype(int)
    want = np.rint((a * np.array([0.9, 0.9, 0.1]) + (1 - a) * np.array([0.2, 0.2, 0.9])) * 255)
    assert np.abs(img[H // 2, W // 2] - want).max() <= 1
    assert np.abs(img[H // 2, W // 2 + 45] - np.rint(np.array([0.2, 0.2, 0.9]) * 255)).max() <= 1


def test_frames_repeat_exactly(scene, raster):
    """The same scene drawn again gives the same image, with every studio term on (shadows, highlights,
    edge filter, a see-through part, particles and lines)."""
    _ball_over_floor(scene, [0.5, 1.0, 0.3])
    scene.lighting.antialias = scene.lighting.specular = True
    vp, fp = box_mesh([0.1, 0.1, 0.005], center=[0.1, 0.12, 0.0])
    vb, fb = sphere_mesh(RADIUS)
    vg, fg = ground_quad(0.0, 1.0)
    scene.set_surfaces([MeshPart(vg, fg, -1, colors=FLOOR), MeshPart(vb, fb, 0, colors=BALL),
                        MeshPart(vp, fp, -1, colors=(0.7, 0.85, 0.9), opacity=0.3, roughness=0.1)])
    scene.set_particles([[0.15, 0.05, 0.1], [-0.1, 0.02, 0.05]], 0.02)
    a, b = disc_outline([0.0, 0.01, 0.0], [0, 1, 0], 0.2, 24)
    scene.set_lines(a, b, width=2)
    scene.update()
    cam = Camera(eye=[0.5, 0.6, 0.7], target=[0.0, 0.1, 0.0], near=0.05, far=10.0)
    first = raster.render(scene, cam)
    assert len(np.unique(first.reshape(-1, 3), axis=0)) > 50
    for _ in range(5):
        assert np.array_equal(raster.render(scene, cam), first)


def test_auto_renderer_is_the_rasteriser(taichi_runtime):
    r = make_renderer("auto", 64, 48)
    try:
        assert r.name == "raster" and "auto -> raster" in r.message
    finally:
        r.release()
