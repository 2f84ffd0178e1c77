"""The Taichi rasteriser and the frame buffers: pose transform, visibility, depth order, orientation,
Lambert colours, perspective-correct interpolation, particles, near-plane clipping and lines."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from geometry.surface import SurfaceMesh
from render.camera import Camera
from render.primitives import box_mesh, ground_quad
from render.raster import RasterRenderer
from render.scene_data import MIN_CAPACITY, Lighting, MeshPart, RenderScene
from rigid.quat import quat_from_axis_angle, quat_to_matrix

W, H = 160, 120
AMB, LIGHT = 0.25, 0.75  # ambient + light = 1: a face lit head-on shows its own colour


def _bg(scene: RenderScene) -> np.ndarray:
    return np.rint(scene.lighting.background * 255).astype(np.uint8)


def _mask(img: np.ndarray, scene: RenderScene) -> np.ndarray:
    return np.any(img != _bg(scene), axis=-1)


def _rgb(c) -> np.ndarray:
    return np.rint(np.clip(np.asarray(c, dtype=np.float64), 0, 1) * 255).astype(int)


@pytest.fixture(scope="module")
def raster(taichi_runtime):
    r = RasterRenderer(W, H)
    yield r
    r.release()


def _front_camera(dist: float = 1.0) -> Camera:
    return Camera(eye=[0.0, 0.0, dist], target=[0.0, 0.0, 0.0], fov_deg=45.0, near=0.05, far=20.0)


def _head_on_light(cam: Camera, two_sided: bool = False) -> Lighting:
    return Lighting(light_dir=cam.eye - cam.target, ambient=[AMB] * 3, light_color=[LIGHT] * 3, two_sided=two_sided)


def _reset(scene: RenderScene, lighting: Lighting) -> None:
    scene.lighting = lighting
    scene.set_particles(np.zeros((0, 3)), 1.0)
    scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))


def test_transform_matches_quaternion_formula(scene):
    """World corners = R(q) (X - ref_com) + x per body (w-x-y-z), static parts untouched, unit outward normals."""
    v0, f0 = box_mesh([0.1, 0.05, 0.02], center=[0.3, 0.1, 0.0])
    v1, f1 = box_mesh([0.02, 0.02, 0.2])
    vg, fg = ground_quad(-0.5, 2.0)
    scene.set_surfaces([MeshPart(v0, f0, 0), MeshPart(v1, f1, 1), MeshPart(vg, fg, -1)])
    rng = np.random.default_rng(3)
    q = np.stack([quat_from_axis_angle(rng.normal(size=3), a) for a in (0.7, -2.1)])
    q[1] *= 3.0  # not unit: the kernel normalises
    x = rng.normal(size=(2, 3))
    com = np.array([[0.3, 0.1, 0.0], [0.01, -0.02, 0.03]])
    scene.set_poses(x, q, com)
    scene.update()
    got = scene.corner_x.to_numpy()[: 3 * scene.n_tris].reshape(-1, 3, 3)
    nrm = scene.corner_n.to_numpy()[: 3 * scene.n_tris].reshape(-1, 3, 3)
    want = np.concatenate([
        (v0[f0] - com[0]) @ quat_to_matrix(q[0] / np.linalg.norm(q[0])).T + x[0],
        (v1[f1] - com[1]) @ quat_to_matrix(q[1] / np.linalg.norm(q[1])).T + x[1],
        vg[fg],
    ])
    assert np.allclose(got, want, atol=1e-12)
    n = np.cross(want[:, 1] - want[:, 0], want[:, 2] - want[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.allclose(nrm, n[:, None, :], atol=1e-12)
    centres = [(x[0], 12), (x[1], 12)]  # outward: normal points away from the body's centre
    start = 0
    for c, nf in centres:
        d = want[start : start + nf].mean(1) - c
        assert np.all(np.einsum("ij,ij->i", d, n[start : start + nf]) > 0)
        start += nf


def test_box_visible_and_moves(scene, raster):
    """The box covers its projected bounding box (and nothing outside), and a moved box changes the frame."""
    cam = Camera(eye=[0.5, 0.4, 0.8], target=[0.0, 0.0, 0.0], near=0.05, far=10.0)
    _reset(scene, Lighting())
    v, f = box_mesh([0.1, 0.1, 0.1])
    scene.set_surfaces([MeshPart(v, f, 0, colors=(0.8, 0.5, 0.3))])
    frames, masks = [], []
    for x, q in (([0, 0, 0], [1, 0, 0, 0]), ([0.05, -0.03, 0.0], quat_from_axis_angle([0.2, 1, 0], 0.5))):
        scene.set_poses([x], [q], [[0, 0, 0]])
        scene.update()
        img = raster.render(scene, cam)
        assert img.shape == (H, W, 3) and img.dtype == np.uint8
        m = _mask(img, scene)
        world = (v - 0) @ quat_to_matrix(np.asarray(q, float)).T + np.asarray(x, float)
        px, _, _ = cam.project(world, W, H)
        x0, y0 = np.floor(px.min(0)).astype(int)
        x1, y1 = np.ceil(px.max(0)).astype(int)
        inside = m[max(y0, 0) : y1, max(x0, 0) : x1]
        assert inside.mean() > 0.5  # a box's outline fills most of its bounding box
        outside = m.copy()
        outside[max(y0 - 1, 0) : y1 + 1, max(x0 - 1, 0) : x1 + 1] = False
        assert not outside.any()
        frames.append(img)
        masks.append(m)
    changed = np.any(frames[0] != frames[1], axis=-1)
    assert changed.mean() > 0.02


@pytest.mark.parametrize("order", ["near_first", "far_first"])
def test_depth_order_independent(scene, raster, order):
    """A near triangle hides a far one whatever the order of the triangles (and of their bodies)."""
    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    tri = np.array([[-0.3, -0.3, 0.0], [0.3, -0.3, 0.0], [0.0, 0.3, 0.0]])
    near = MeshPart(tri + [0, 0, 0.1], np.array([[0, 1, 2]]), -1, colors=(0.9, 0.1, 0.1))
    far = MeshPart(tri * 1.5 - [0, 0, 0.1], np.array([[0, 1, 2]]), -1, colors=(0.1, 0.1, 0.9))
    scene.set_surfaces([near, far] if order == "near_first" else [far, near])
    scene.set_poses(np.zeros((0, 3)), np.zeros((0, 4)), np.zeros((0, 3)))
    scene.update()
    img = raster.render(scene, cam)
    assert np.abs(img[H // 2, W // 2].astype(int) - _rgb([0.9, 0.1, 0.1])).max() <= 1
    m_far = np.abs(img.astype(int) - _rgb([0.1, 0.1, 0.9])).max(-1) <= 1
    assert m_far.sum() > 100  # the far triangle shows around the near one
    # the same image either way
    if order == "far_first":
        scene.set_surfaces([near, far])
        assert np.array_equal(raster.render(scene, cam), img)


def test_orientation(scene, raster):
    """Row 0 is the top of the image and column 0 its left (camera up and right)."""
    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    v, f = box_mesh([0.05, 0.05, 0.05])
    scene.set_surfaces([MeshPart(v, f, 0, colors=(0.2, 0.8, 0.2))])
    scene.set_poses([[0.2, 0.15, 0.0]], [[1, 0, 0, 0]], [[0, 0, 0]])  # up and to the right
    scene.update()
    ys, xs = np.nonzero(_mask(raster.render(scene, cam), scene))
    assert ys.max() < H // 2 and xs.min() > W // 2


@pytest.mark.parametrize("angle_deg,two_sided", [(0.0, False), (60.0, False), (120.0, False), (120.0, True)])
def test_lambert_colour(scene, raster, angle_deg, two_sided):
    """A face of colour c lit at angle a shows c (ambient + light max(cos a, 0)) (|cos a| two-sided)."""
    cam = _front_camera()
    a = np.radians(angle_deg)
    lt = Lighting(light_dir=[np.sin(a), 0.0, np.cos(a)], ambient=[0.2] * 3, light_color=[0.7] * 3,
                  two_sided=two_sided)
    _reset(scene, lt)
    quad = np.array([[-0.3, -0.3, 0], [0.3, -0.3, 0], [0.3, 0.3, 0], [-0.3, 0.3, 0]])
    c = np.array([0.8, 0.4, 0.2])
    scene.set_surfaces([MeshPart(quad, np.array([[0, 1, 2], [0, 2, 3]]), -1, colors=c)])
    img = raster.render(scene, cam)
    cos = abs(np.cos(a)) if two_sided else max(np.cos(a), 0.0)
    assert np.abs(img[H // 2, W // 2].astype(int) - _rgb(c * (0.2 + 0.7 * cos))).max() <= 1


def test_perspective_correct_colour(scene, raster):
    """Colours follow the 3D barycentrics of the point seen through each pixel, not screen-space ones."""
    cam = Camera(eye=[0.0, 0.25, 0.6], target=[0.0, 0.0, -0.3], near=0.05, far=10.0)
    _reset(scene, Lighting(light_dir=[0, 1, 0], ambient=[AMB] * 3, light_color=[LIGHT] * 3))
    tri = np.array([[-0.5, 0.0, 0.4], [0.5, 0.0, 0.4], [0.0, 0.0, -2.0]])  # a floor triangle going far away
    cols = np.eye(3)
    scene.set_surfaces([MeshPart(tri, np.array([[0, 1, 2]]), -1, colors=cols, color_per="vertex")])
    img = raster.render(scene, cam).astype(int)
    px, _, _ = cam.project(tri, W, H)
    checked = 0
    for x, y in [(W // 2, int(H * 0.55)), (W // 2 + 10, int(H * 0.7)), (W // 2 - 5, int(H * 0.45))]:
        o, d = cam.ray(x + 0.5, y + 0.5, W, H)
        n = np.array([0.0, 1.0, 0.0])
        p = o + d * ((tri[0] - o) @ n) / (d @ n)
        # 3D barycentrics of p
        t = np.linalg.lstsq(np.c_[tri[1] - tri[0], tri[2] - tri[0]], p - tri[0], rcond=None)[0]
        bary = np.array([1 - t.sum(), t[0], t[1]])
        if bary.min() < 0.02:
            continue
        # screen-space (affine) barycentrics of the pixel centre, for contrast
        s = np.linalg.solve(np.c_[px[1] - px[0], px[2] - px[0]], np.array([x + 0.5, y + 0.5]) - px[0])
        affine = np.array([1 - s.sum(), s[0], s[1]])
        assert np.abs(_rgb(affine) - _rgb(bary)).max() > 10  # the test can tell them apart
        assert np.abs(img[y, x] - _rgb(bary)).max() <= 1
        checked += 1
    assert checked >= 2


def test_particles_depth_and_size(scene, raster):
    """Particles: discs of the projected radius, shaded as spheres, hidden behind nearer faces."""
    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0.0]])
    scene.set_surfaces([MeshPart(quad, np.array([[0, 1, 2], [0, 2, 3]]), -1, colors=(0.3, 0.3, 0.3))])
    r = 0.08
    scene.set_particles([[0.0, 0.0, 0.2], [0.25, 0.0, -0.2]], r, colors=[[0.9, 0.5, 0.1], [0.1, 0.9, 0.1]])
    img = raster.render(scene, cam)
    assert np.abs(img[H // 2, W // 2].astype(int) - _rgb([0.9, 0.5, 0.1])).max() <= 1  # normal faces the light
    orange = np.abs(img.astype(int) - _rgb([0.3, 0.3, 0.3])).max(-1) > 1
    focal = 1.0 / np.tan(np.radians(22.5)) * H / 2
    expected_r = focal * r / 0.8
    assert abs(np.sqrt(orange.sum() / np.pi) - expected_r) < 1.0
    assert not np.any(img[:, :, 1] > 200)  # the green one is behind the quad
    # shading darkens towards the rim
    row = img[H // 2, W // 2 : W // 2 + int(expected_r) - 1, 0].astype(int)
    assert row[0] > row[-1] + 40


def test_near_plane_clipping(scene, raster):
    """A floor reaching behind the camera is clipped, not dropped: the lower image shows it, the sky does not."""
    cam = Camera(eye=[0.0, 0.3, 0.0], target=[0.0, 0.25, -1.0], near=0.05, far=200.0)
    _reset(scene, Lighting(light_dir=[0, 1, 0]))
    v, f = ground_quad(0.0, 50.0)
    scene.set_surfaces([MeshPart(v, f, -1, colors=(0.5, 0.5, 0.5))])
    m = _mask(raster.render(scene, cam), scene)
    (edge,), _, _ = cam.project(np.array([[0.0, 0.0, -50.0]]), W, H)  # far edge of the floor
    assert 10 < edge[1] < H - 10
    assert m[int(np.ceil(edge[1])) + 1 :].all()  # every row below the far edge, down to the bottom
    assert not m[: int(np.floor(edge[1])) - 1].any()


def test_lines(scene, raster):
    """Lines: flat colour, the requested width in pixels, depth-tested against faces."""
    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    quad = np.array([[0.05, -1, 0], [1, -1, 0], [1, 1, 0], [0.05, 1, 0.0]])
    scene.set_surfaces([MeshPart(quad, np.array([[0, 1, 2], [0, 2, 3]]), -1, colors=(0.3, 0.3, 0.3))])
    scene.set_lines([[-0.3, 0.0, -0.1]], [[0.3, 0.0, -0.1]], colors=(1.0, 1.0, 0.0), width=3)
    img = raster.render(scene, cam)
    yellow = np.all(img == _rgb([1, 1, 0]), axis=-1)
    col = W // 2 - 20  # left of the quad
    assert yellow[:, col].sum() == 3
    assert not yellow[:, W // 2 + 10 :].any()  # behind the quad on the right
    with pytest.raises(ConfigError):
        scene.set_lines([[0, 0, 0]], [[1, 0, 0]], width=100)


def test_fragments_follow_their_bodies(scene, raster):
    """A SurfaceMesh's fragments map to bodies through label_body; moving one body moves only its fragment."""
    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    va, fa = box_mesh([0.08, 0.08, 0.08], center=[-0.15, 0, 0])
    vb, fb = box_mesh([0.08, 0.08, 0.08], center=[0.15, 0, 0])
    mesh = SurfaceMesh(verts=np.r_[va, vb], faces=np.r_[fa, fb + 8], face_label=np.repeat([0, 1], 12),
                       vert_label=np.repeat([0, 1], 8))
    scene.set_surface_mesh(mesh, label_body=[1, 0])  # fragment 0 -> body 1, fragment 1 -> body 0
    com = np.array([[0.15, 0, 0], [-0.15, 0, 0]])
    scene.set_poses(com, [[1, 0, 0, 0]] * 2, com)
    scene.update()
    a = raster.render(scene, cam)
    scene.set_poses(com + [[0, 0.1, 0], [0, 0, 0]], [[1, 0, 0, 0]] * 2, com)
    scene.update()
    b = raster.render(scene, cam)
    diff = np.any(a != b, axis=-1)
    assert not diff[:, : W // 2].any() and diff[:, W // 2 :].sum() > 100


def test_capacity_growth(scene, raster):
    """More triangles than the capacity rebuild the buffers (generation + 1) and still draw correctly;
    no compiled kernel is lost (destroying the old field tree would clear every compiled kernel of the
    program, Taichi 1.7.4, and the next frame would recompile them all)."""
    from taichi.lang import impl

    cam = _front_camera()
    _reset(scene, _head_on_light(cam))
    raster.render(scene, cam)
    compiled = impl.get_runtime().get_num_compiled_functions()
    gen, ver = scene.generation, scene.surface_version
    n = scene.cap["surf"] + 1
    assert n > MIN_CAPACITY
    rng = np.random.default_rng(0)
    centres = rng.uniform(-0.3, 0.3, (n, 3)) * [1, 1, 0.1]
    tris = centres[:, None, :] + np.array([[-0.01, -0.01, 0], [0.01, -0.01, 0], [0, 0.01, 0]])
    scene.set_surfaces([MeshPart(tris.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3), -1, colors=(1, 0, 0))])
    assert scene.generation == gen + 1 and scene.surface_version == ver + 1 and scene.n_tris == n
    assert impl.get_runtime().get_num_compiled_functions() >= compiled
    img = raster.render(scene, cam)
    px, _, _ = cam.project(centres, W, H)
    hit = np.all(img[px[:, 1].astype(int), px[:, 0].astype(int)] == _rgb([1, 0, 0]), axis=-1)
    assert hit.mean() > 0.95


def test_bad_input(scene):
    v, f = box_mesh([0.05, 0.05, 0.05])
    scene.set_surfaces([MeshPart(v, f, -1)])
    before = scene.corner_ref.to_numpy()[: 3 * scene.n_tris].copy(), scene.n_tris, scene.surface_version
    with pytest.raises(ConfigError, match=r"render.surfaces\[7\]\[0\].faces"):  # a bad block changes nothing
        scene.update_surfaces({7: [MeshPart(np.zeros((3, 3)), np.array([[0, 1, 3]]), 0)]}, drop=["all"])
    assert scene.n_tris == before[1] and scene.surface_version == before[2]
    assert np.array_equal(scene.corner_ref.to_numpy()[: 3 * scene.n_tris], before[0])
    with pytest.raises(ConfigError, match="faces"):
        scene.set_surfaces([MeshPart(np.zeros((3, 3)), np.array([[0, 1, 3]]), -1)])
    with pytest.raises(ConfigError, match="colors"):
        scene.set_surfaces([MeshPart(np.eye(3), np.array([[0, 1, 2]]), -1, colors=np.ones((2, 3)))])
    with pytest.raises(ConfigError, match="q"):
        scene.set_poses([[0, 0, 0]], [[0, 0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(ConfigError, match="size"):
        RasterRenderer(0, 10)


def test_copy_from_taichi_fields(scene, raster):
    """Poses and particles copied from Taichi fields (as a rigid store holds them) equal the host upload."""
    import taichi as ti

    from core.runtime import numpy_float

    v, f = box_mesh([0.05, 0.05, 0.05])
    _reset(scene, Lighting())
    scene.set_surfaces([MeshPart(v, f, 0), MeshPart(v + [0.2, 0, 0], f, 1)])
    rng = np.random.default_rng(7)
    x = rng.normal(size=(2, 3)) * 0.1
    q = np.stack([quat_from_axis_angle(rng.normal(size=3), 1.0), quat_from_axis_angle([0, 1, 0], -0.4)])
    com = np.array([[0.0, 0, 0], [0.2, 0, 0]])
    scene.set_poses(x, q, com)
    scene.update()
    want = scene.corner_x.to_numpy()[: 3 * scene.n_tris]
    fb = ti.FieldsBuilder()
    body_x, body_q, body_com = ti.math.vec3.field(), ti.math.vec4.field(), ti.math.vec3.field()
    p_x, p_r = ti.math.vec3.field(), ti.field(float)
    fb.dense(ti.i, 4).place(body_x, body_q, body_com, p_x, p_r)
    fb.finalize()  # kept: destroying a tree clears every compiled kernel of the process (core/field_pool.py)
    pad = np.zeros((2, 3))
    body_x.from_numpy(np.r_[x, pad].astype(numpy_float()))
    body_q.from_numpy(np.r_[q, np.tile([1.0, 0, 0, 0], (2, 1))].astype(numpy_float()))
    body_com.from_numpy(np.r_[com, pad].astype(numpy_float()))
    scene.set_poses(np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)), np.zeros((2, 3)))
    scene.copy_poses_from(body_x, body_q, body_com, 2)
    scene.update()
    assert scene.n_bodies == 2
    assert np.allclose(scene.corner_x.to_numpy()[: 3 * scene.n_tris], want, atol=1e-12)
    p_x.from_numpy(np.array([[0.1, 0.2, 0.3], [0, 0, 0], [0, 0, 0], [0, 0, 0]], dtype=numpy_float()))
    p_r.from_numpy(np.array([0.05, 1, 1, 1], dtype=numpy_float()))
    scene.copy_particles_from(p_x, p_r, 1, color=(0.1, 0.2, 0.3))
    assert scene.n_particles == 1
    assert np.allclose(scene.particle_x.to_numpy()[0], [0.1, 0.2, 0.3])
    assert np.isclose(scene.particle_r.to_numpy()[0], 0.05)
    assert np.allclose(scene.particle_color.to_numpy()[0], [0.1, 0.2, 0.3])
