"""Materials that read in frames: looks from the scene file or the material's kind (render/looks.py),
bad looks named in the error, and the faces a crack created drawn in the crack shade (render/session.py)."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from render.camera import Camera
from render.looks import DEFAULT_LOOK, material_look
from render.raster import RasterRenderer
from render.scene_data import Lighting
from render.session import SceneView
from scenes.loader import load_scene
from sim.world import World

SPLIT_BOX = """
[scene]
name = "split_box"
effects = ["rigid", "fracture", "subdivision"]
frames = 2
[[materials]]
name = "porcelain"
density = 2400.0
stiffness = { model = "isotropic", E = 7.0e10, nu = 0.2 }
look = { color = [0.9, 0.9, 0.85], crack_color = [0.2, 0.6, 0.3] }
[[objects]]
name = "box"
shape = { type = "box", size = [0.2, 0.1, 0.1] }
material = "porcelain"
resolution = 0.04
position = [0.0, 0.05, 0.0]
[[cracks]]
frame = 0
object = "box"
point = [0.0, 0.05, 0.0]
normal = [1.0, 0.0, 0.0]
[[colliders]]
type = "plane"
"""


def test_kind_defaults_and_overrides():
    assert material_look("soda_lime_glass").opacity < 1.0
    assert material_look("black_slate").color[0] < 0.2 < material_look("white_marble").color[0]
    assert material_look("unobtainium") == DEFAULT_LOOK
    lk = material_look("glass", {"opacity": 0.8, "color": [0.1, 0.2, 0.3]})
    assert lk.opacity == 0.8 and lk.color == (0.1, 0.2, 0.3) and lk.roughness == material_look("glass").roughness
    # a crack shade differs from the base colour, lighter on dark stone and darker on white
    dark, white = material_look("black_slate"), material_look("white_marble")
    assert dark.crack()[0] > dark.color[0] and white.crack()[0] < white.color[0]


def test_the_two_tai_chi_materials_are_black_and_white():
    cfg = load_scene("taichi")
    lum = sorted(np.mean(m.appearance.color) for m in cfg.materials)
    assert lum[0] < 0.2 and lum[1] > 0.8


@pytest.mark.parametrize("look,key", [({"color": [1.2, 0, 0]}, "color"), ({"opacity": 0.0}, "opacity"),
                                      ({"roughness": "shiny"}, "roughness"), ({"shine": 1}, "shine")])
def test_bad_look_is_named(tmp_path, look, key):
    items = ", ".join(f"{k} = {v!r}".replace("'", '"') for k, v in look.items())
    text = SPLIT_BOX.replace('look = { color = [0.9, 0.9, 0.85], crack_color = [0.2, 0.6, 0.3] }',
                             f"look = {{ {items} }}")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=rf"materials\[0\]\.look\.{key}"):
        load_scene(str(path))


@pytest.fixture
def split_world(tmp_path, taichi_runtime):
    path = tmp_path / "split_box.toml"
    path.write_text(SPLIT_BOX)
    world = World(load_scene(str(path)))
    view = SceneView(world)  # before the crack: the rest surface is the box's
    world.step_frame()  # the scripted crack at frame 0 splits the box at x = 0
    view.refresh()
    yield world, view
    view.release()
    world.release()


def test_crack_faces_are_the_faces_on_the_cut(split_world):
    """After the cut the faces classified as crack faces are exactly those on the plane x = 0."""
    from render.session import world_surfaces

    world, view = split_world
    assert world.fragment_count() == 2
    mesh = world_surfaces(world)
    outer = view.blocks.outer_faces(mesh.face_id, mesh.verts, mesh.faces)
    centre = mesh.verts[mesh.faces].mean(1)
    on_cut = np.abs(centre[:, 0]) < 1e-9
    assert on_cut.any() and np.array_equal(~outer, on_cut)


def test_one_search_for_every_changed_body_answers_as_one_search_per_body(split_world):
    """SurfaceBlocks classifies the faces of all the bodies an event changed in one search of the rest
    surface: each body's faces get the answer a search for that body alone gives."""
    world, view = split_world
    blocks = view.blocks
    bodies = list(blocks._surfaces.body_ids())
    assert len(bodies) == 2
    for b in bodies:
        _, verts, faces, fid = blocks._surfaces.body_mesh(b)
        alone = blocks._rest.covers(verts[faces], blocks._tol)
        assert np.all(blocks._outer[fid] >= 0)  # classified by the event's one search
        assert np.array_equal(blocks._outer[fid] == 1, alone)
        assert alone.any() and not alone.all()  # each half has outer and crack faces


@pytest.mark.parametrize("scene", ["pot", "taichi"])
def test_the_rest_surface_faces_are_outer_without_the_search(scene, taichi_runtime):
    """SurfaceBlocks marks the rest surface's own faces outer from their ids, without the search (Pots'
    first blocks: 0.27 s); the search says the same of every one of them, on a curved object and on
    one of two materials."""
    from geometry.surface import RestSurface
    from render.session import rest_surface
    from render.surface_blocks import SurfaceBlocks

    world = World(load_scene(scene))
    try:
        tris, ids = rest_surface(world)
        view = SceneView(world)
        tol = view.blocks._tol
        view.release()
    finally:
        world.release()
    assert len(ids) == len(tris) > 0
    assert RestSurface(tris).covers(tris, tol).all()
    blocks = SurfaceBlocks(tris, [DEFAULT_LOOK], "material", tol, None, 0.0, rest_ids=ids)
    seeded = blocks._outer.copy()
    assert np.all(seeded[ids] == 1) and np.all(np.delete(seeded, ids) == -1)


def test_crack_face_pixels_take_the_crack_shade(split_world):
    """Seen from inside the right half (its faces are back faces, culled), the left half's crack face
    fills the view in the crack shade; lit head-on with ambient + light = 1, the pixel is that colour."""
    world, view = split_world
    scene = view.scene
    scene.lighting = Lighting(light_dir=[1, 0, 0], ambient=[0.25] * 3, light_color=[0.75] * 3)
    cam = Camera(eye=[0.02, 0.05, 0.0], target=[-1.0, 0.05, 0.0], near=1e-3, far=10.0, fov_deg=30.0)
    r = RasterRenderer(64, 48)
    try:
        img = r.render(scene, cam).astype(int)
    finally:
        r.release()
    want = np.rint(np.array([0.2, 0.6, 0.3]) * 255)
    assert np.abs(img[24, 32] - want).max() <= 2


def _faces_by_label(mesh) -> list:
    tri = mesh.verts[mesh.faces]
    key = np.concatenate([mesh.face_label[:, None].astype(float), tri.reshape(-1, 9), mesh.face_id[:, None]], 1)
    return sorted(map(tuple, key.tolist()))


def test_surface_cache_equals_a_full_rebuild(taichi_runtime):
    """Surfaces rebuilt only for the bodies a fracture changed are the full rebuild's, face for face,
    through the glass pane's event (cracks, subdivision, shatter) and the frames after it."""
    from render.session import world_surfaces
    from render.surface_blocks import SurfaceCache

    world = World(load_scene("glass_r3"))
    cache = SurfaceCache()
    try:
        for _ in range(5):
            world.step_frame()
            assert _faces_by_label(cache.surfaces(world)) == _faces_by_label(world_surfaces(world))
        assert world.events and world.fragment_count() > 2
    finally:
        world.release()


def test_a_first_refresh_reads_the_kept_host_copy(taichi_runtime):
    """A consumer's first refresh, where the store's whole content is on the host already (after the
    build, or after a download), cuts the surfaces from that copy and launches no take kernel; they
    are the full rebuild's, face for face, also after the glass pane's event (fragments, children,
    debris)."""
    from render.session import world_surfaces
    from render.surface_blocks import SurfaceCache

    world = World(load_scene("glass_r3"))
    try:
        for frames in (0, 5):
            for _ in range(frames):
                world.step_frame()
            full = _faces_by_label(world_surfaces(world))  # downloads the store: the copy is kept
            assert world.store.kept_host() is not None
            world.store.transfers.clear()
            assert _faces_by_label(SurfaceCache().surfaces(world)) == full
            assert "take_bodies" not in [name for name, _ in world.store.transfers]
        assert world.events and world.fragment_count() > 2
        world.store.put_body(*world.store.take_bodies([]))  # any write moves the store's version
        assert world.store.kept_host() is None  # the next first refresh takes the bodies
    finally:
        world.release()


def _drawn_triangles(scene) -> list:
    """The triangles a RenderScene draws, as sorted rows (reference corners, body, colours, looks);
    blanked ones (static, every corner at the origin) left out."""
    n = scene.n_tris
    ref = scene.corner_ref.to_numpy()[: 3 * n].reshape(n, 9)
    body = scene.corner_body.to_numpy()[: 3 * n].reshape(n, 3)
    col = scene.corner_color.to_numpy()[: 3 * n].reshape(n, 9)
    look = scene.corner_look.to_numpy()[: 3 * n].reshape(n, 6)
    blank = (body[:, 0] == -1) & np.all(ref == 0.0, axis=1)
    rows = np.concatenate([ref, body, col, look], axis=1)[~blank]
    return sorted(map(tuple, rows.tolist()))


@pytest.mark.parametrize("colors", ["material", "fragments"])
def test_incremental_refresh_draws_what_a_full_rebuild_draws(taichi_runtime, colors):
    """A view refreshed frame by frame through the glass pane's event (only the changed bodies' blocks
    written, the broken pane's blanked) holds the triangles of a view built afterwards in one piece,
    triangle for triangle; the blanked ones are still in its buffers, so the partial path ran."""
    world = World(load_scene("glass_r3"))
    view = SceneView(world, colors=colors)
    try:
        for _ in range(5):
            world.step_frame()
            view.refresh()
        assert world.events and world.fragment_count() > 2
        full = SceneView(world, colors=colors)
        try:
            assert _drawn_triangles(view.scene) == _drawn_triangles(full.scene)
            assert view.scene._blank > 0 and full.scene._blank == 0
        finally:
            full.release()
    finally:
        view.release()
        world.release()
