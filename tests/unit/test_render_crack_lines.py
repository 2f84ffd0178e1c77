"""Crack lines (render/crack_lines.py): the rim where crack faces meet the outer surface, drawn as ribbons
on the outer faces. Known answers: a cube with one face marked as a crack has that face's square as its
rim; the ribbons lie on their faces, lifted by `lift`, at most half the face's height wide; a box cut in
two by a plane has the cut section's perimeter as each half's rim, and in a frame the line shows exactly
where the cut meets the face seen."""

from __future__ import annotations

import numpy as np
import pytest

from render.camera import Camera
from render.crack_lines import LINE_DARK, LINE_LIGHT, line_color, ribbons, rim_edges
from render.looks import material_look
from render.raster import RasterRenderer
from render.scene_data import Lighting
from render.session import SceneView
from scenes.loader import load_scene
from sim.world import World
from tests.unit.test_render_materials import SPLIT_BOX

# a unit cube: 8 shared corners, 12 outward (counter-clockwise from outside) triangles, two per side
CUBE_V = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
CUBE_F = np.array([
    [0, 1, 3], [0, 3, 2],  # x = 0
    [4, 6, 7], [4, 7, 5],  # x = 1
    [0, 4, 5], [0, 5, 1],  # y = 0
    [2, 3, 7], [2, 7, 6],  # y = 1
    [0, 2, 6], [0, 6, 4],  # z = 0
    [1, 5, 7], [1, 7, 3],  # z = 1
])
ON_X1 = np.isin(np.arange(12), [2, 3])  # the two triangles of the side x = 1


def _outward(v, f) -> bool:
    c = v[f].mean(1) - v.mean(0)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return bool(np.all(np.einsum("ij,ij->i", n, c) > 0))


def test_rim_of_one_crack_side_is_its_square():
    assert _outward(CUBE_V, CUBE_F)
    edges, face = rim_edges(CUBE_F, ~ON_X1)
    a, b = CUBE_V[edges[:, 0]], CUBE_V[edges[:, 1]]
    assert len(edges) == 4 and np.allclose(a[:, 0], 1.0) and np.allclose(b[:, 0], 1.0)
    assert np.linalg.norm(b - a, axis=1).sum() == pytest.approx(4.0)  # the square, not its diagonal
    assert not ON_X1[face].any()  # each edge is given with the outer face it borders
    # every rim edge directed as in its outer face (that face's boundary runs a -> b)
    for (i, j), f in zip(edges, face):
        k = list(CUBE_F[f]).index(i)
        assert CUBE_F[f][(k + 1) % 3] == j
    # no crack face, or nothing but crack faces: no rim
    assert len(rim_edges(CUBE_F, np.ones(12, bool))[0]) == 0 and len(rim_edges(CUBE_F, np.zeros(12, bool))[0]) == 0


def test_ribbons_lie_on_their_faces():
    width, lift = 0.1, 0.01
    v, f, on = ribbons(CUBE_V, CUBE_F, ~ON_X1, width, lift)
    assert len(f) == 8
    tri = CUBE_V[CUBE_F[on]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    rib = v[f]
    # lifted by `lift` off the plane of the face it lies on, facing the same way
    for k in range(3):
        assert np.allclose(np.einsum("ij,ij->i", rib[:, k] - tri[:, 0], n), lift)
    rn = np.cross(rib[:, 1] - rib[:, 0], rib[:, 2] - rib[:, 0])
    assert np.all(np.einsum("ij,ij->i", rn, n) > 0)
    # within `width` of the side x = 1 and inside the unit square of the face
    x = v - lift * n[0::2][np.arange(len(v)) // 4]  # back on the face: n of each quad's face
    assert np.all(x[:, 0] >= 1.0 - width - 1e-12) and np.all((x >= -1e-12) & (x <= 1 + 1e-12))
    # each rim edge (length 1) is a leg of a right triangle (height 1 over it): its strip of width w is
    # the trapezoid of parallel sides 1 and 1 - w
    area = 0.5 * np.linalg.norm(rn, axis=1).sum()
    assert area == pytest.approx(4.0 * width * (1.0 - width / 2.0))


def test_ribbon_never_leaves_its_face():
    """A sliver face (height 0.02 over its long edge) is covered up to its apex, not 0.1 beyond it, and
    every ribbon stays inside the face."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.02, 0.0], [0.5, 0.0, -1.0]])
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 2, 3], [2, 1, 3]])
    outer = np.array([True, False, False, False])
    rv, rf, _ = ribbons(v, f, outer, 0.1, 0.0)
    assert len(rf) == 6  # all three edges of the sliver border crack faces
    long_edge = [k for k in range(3) if np.allclose(rv[4 * k: 4 * k + 2, 1], 0.0)]
    assert len(long_edge) == 1 and rv[4 * long_edge[0]: 4 * long_edge[0] + 4, 1].max() == pytest.approx(0.02)
    # inside the triangle (0,0), (1,0), (0.5,0.02) of the plane z = 0
    x, y = rv[:, 0], rv[:, 1]
    assert np.allclose(rv[:, 2], 0.0) and np.all(y >= -1e-12)
    assert np.all(y <= 0.04 * np.minimum(x, 1.0 - x) + 1e-12)


def test_line_colour_stands_out():
    assert line_color(material_look("porcelain").color, 1.0) == LINE_DARK
    assert line_color(material_look("black_slate").color, 1.0) == LINE_LIGHT
    glass = material_look("soda_lime_glass")
    assert line_color(glass.color, glass.opacity) == LINE_LIGHT


@pytest.fixture
def split(tmp_path, taichi_runtime):
    path = tmp_path / "split_box.toml"
    path.write_text(SPLIT_BOX.replace("frames = 2", "frames = 2\ngravity = [0.0, 0.0, 0.0]"))
    world = World(load_scene(str(path)))
    views = [SceneView(world, crack_lines=True), SceneView(world, crack_lines=False)]
    world.step_frame()  # the scripted crack at frame 0 cuts the box at x = 0; no gravity: the halves stay
    for view in views:
        view.refresh()
    yield world, views
    for view in views:
        view.release()
    world.release()


def test_each_half_of_a_cut_box_has_the_section_as_rim(split):
    """The box 0.2 x 0.1 x 0.1 m cut at x = 0: each half's crack lines run around the 0.1 x 0.1 m
    section (0.4 m), within a ribbon's width of the cut, and move with that half's body."""
    world, (view, _) = split
    assert world.fragment_count() == 2
    assert sorted(view.blocks._ribbons) == sorted(world.bodies)
    for body, (rv, _, _) in view.blocks._ribbons.items():
        a, b = rv[0::4], rv[1::4]  # each quad starts with its rim edge (lifted)
        assert np.linalg.norm(b - a, axis=1).sum() == pytest.approx(0.4, rel=1e-9)
        assert np.abs(a[:, 0]).max() < 1e-9 and np.abs(rv[:, 0]).max() <= view.blocks._line_width + 1e-9
        side = np.sign(world.particles.centroid[world.particles.body == body, 0].mean())
        assert np.all(rv[:, 0] * side >= -1e-9)  # on its own half


def test_the_line_is_drawn_where_the_cut_meets_the_face(split):
    """Seen head-on, the front face (z = 0.05) with and without crack lines differs only in the columns
    around x = 0 (within the two ribbons' width and a pixel), and there it is darker. The halves drawn
    where they were cut (their reference pose: the contact between them pushes them apart after the
    cut); plain lighting: the studio's shadow map is fitted to the scene's bounds, which the lifted
    ribbons move a little."""
    world, (lines, plain) = split
    com = world.rigid._s.body_ref_com.to_numpy()[: world.rigid.n_bodies]
    for view in (lines, plain):
        view.scene.lighting = Lighting(light_dir=[0.2, 0.5, 1.0])
        view.scene.set_poses(com, np.tile([1.0, 0.0, 0.0, 0.0], (len(com), 1)), com)
        view.scene.update()
    w, h = 160, 120
    cam = Camera(eye=[0.0, 0.05, 0.5], target=[0.0, 0.05, 0.0], fov_deg=30.0, near=0.05, far=5.0)
    r = RasterRenderer(w, h)
    try:
        on = r.render(lines.scene, cam).astype(int)
        off = r.render(plain.scene, cam).astype(int)
    finally:
        r.release()
    m_per_px = 2 * 0.45 * np.tan(np.radians(15.0)) / h  # at the front face, 0.45 m from the eye
    half = lines.blocks._line_width / m_per_px + 1  # px: one ribbon each side of the cut, plus a pixel
    cols = np.flatnonzero(np.abs(on - off).max(axis=(0, 2)) > 0)
    assert len(cols) and np.abs(cols - (w - 1) / 2).max() <= half
    centre = (w - 1) // 2
    assert on[h // 2, centre].sum() < off[h // 2, centre].sum() - 100
