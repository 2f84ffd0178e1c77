"""Headless frames of a World: surfaces from the fragment tets, poses from the rigid store, a
renderer (the rasteriser by default, or GGUI), the following camera (render/framing.py), and the
PNG and video writers (DESIGN.md section 7).

Surfaces are rebuilt only when fracture changed them (`World.surface_version`), and then only for the
bodies it changed: each body is one block of the render buffers (RenderScene.update_surfaces), coloured
by each material's look with crack faces in its crack shade (render/surface_blocks.py); every frame one
kernel moves them by the body poses, read straight from the rigid store's fields (or, for a drawing
process, render/draw_process.py, through the stores' download kernels).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import ConfigError
from render.camera import Camera
from render.crack_lines import LIFT_REL, LINE_WIDTH_REL
from render.framing import FollowCamera
from render.looks import material_look
from render.primitives import ground_quad
from render.scene_data import Lighting, MeshPart, RenderScene
from render.select import make_renderer
from render.surface_blocks import SurfaceBlocks, surface_changes
from render.writers import PngSequenceWriter, make_writer

FLOOR_COLOR = (0.55, 0.55, 0.58)


def world_surfaces(world):
    """Closed surfaces of every body (labels = body ids), from the alive tet particles."""
    from geometry.surface import fragment_surfaces

    ps = world.particles
    labels = np.where(ps.alive, ps.body, -1).astype(np.int64)
    return fragment_surfaces(ps, labels)


def rest_surface(world) -> tuple[np.ndarray, np.ndarray]:
    """The objects' surface before anything broke, in the reference frame: the built tets' faces that
    had no face neighbour (World.rest_open_faces), as triangles (T, 3, 3) m and tet face ids (T,)
    (particle * 4 + k; the built particles' store ids are their rows)."""
    from geometry.subdivision import face_points

    p, k = np.nonzero(world.rest_open_faces)
    return face_points(world.particles.rest_verts[p])[np.arange(len(p)), k], p.astype(np.int64) * 4 + k


def material_looks(world) -> list:
    """The look of every material id of the world's particles: the scene's materials, then any the
    world added later (the viewer's steel ball), looked up by name."""
    looks = [m.appearance for m in world.cfg.materials]
    looks += [material_look(m.name) for m in world.materials[len(looks):]]
    return looks


def debris_color(world) -> tuple:
    """Shattered particles (the `debris` effect) in the crack shade of the first breakable material."""
    cfg = world.cfg
    obj = next((o for o in cfg.objects if o.breakable), cfg.objects[0])
    return cfg.material(obj.material).appearance.crack()


def camera_for(world, aspect: float) -> Camera:
    c = world.cfg.camera
    return Camera(eye=c.eye, target=c.target, fov_deg=c.fov)


def floor_height(world) -> float | None:
    """m: height of the lowest horizontal plane collider (the floor), None without one."""
    ys = [c.point[1] for c in world.cfg.colliders if c.type == "plane" and abs(c.normal[1]) > 0.99]
    return min(ys) if ys else None


COLOR_MODES = ("material", "fragments")  # --colors: each material's look, or one colour per fragment
ON_SURFACE_REL = 1e-7  # -: a face within this share of the scene's size of the rest surface is an outer face
# -: triangle capacity reserved, in multiples of the objects' rest surface: the rest surface, the crack
# faces of the first events (about as many again, twice over) and their crack lines (two per rim edge)
SURFACE_HEADROOM = 4


class SceneView:
    """The renderable state of a World, kept in step with it (shared by headless runs and the viewer):
    the bodies' surface blocks (render/surface_blocks.py: colours by `colors`, "material" or
    "fragments", and `crack_lines`), the floor, the poses and the debris. With `scene_factory` a
    render.draw_process.SceneFeed, the blocks are made in the drawing process from what changed."""

    def __init__(self, world, colors: str = "material", crack_lines: bool = True, scene_factory=RenderScene) -> None:
        if colors not in COLOR_MODES:
            raise ConfigError("--colors", colors, ", ".join(COLOR_MODES))
        self.world = world
        rest, rest_ids = rest_surface(world) if "rigid" in world.stages else (np.zeros((0, 3, 3)), None)
        # room for the crack faces and debris of the first events, and a pose for every body the rigid
        # store can hold: a larger buffer is a new Taichi field, and the render kernels that read it
        # recompile (about 2 s for the surfaces; Pots' pose buffer grew past 64 and 128 bodies, 0.1-0.2 s)
        self.scene = scene_factory(tri_capacity=SURFACE_HEADROOM * len(rest) + 2,
                                   body_capacity=world.rigid.capacity["bodies"] if "rigid" in world.stages else 0,
                                   particle_capacity=world.physical_count if "debris" in world.stages else 0,
                                   lighting=Lighting.studio())
        self._host_side = getattr(self.scene, "host_side", False)  # a SceneFeed: host arrays, blocks made there
        self._version = -1
        self._floor = []
        for col in world.cfg.colliders:
            if col.type == "plane" and abs(col.normal[1]) > 0.99:
                v, f = ground_quad(height=col.point[1], half_size=2.0)
                self._floor.append(MeshPart(v, f, body=-1, colors=FLOOR_COLOR, roughness=0.9))
        self.looks = material_looks(world)
        size = float(np.ptp(rest.reshape(-1, 3), axis=0).max()) if len(rest) else 1.0
        edge = np.median(np.linalg.norm(rest - np.roll(rest, 1, axis=1), axis=2)) if len(rest) else 0.0
        blocks = dict(rest=rest, rest_ids=rest_ids, looks=self.looks, colors=colors,
                      tol=ON_SURFACE_REL * max(size, 1e-3), line_width=LINE_WIDTH_REL * edge if crack_lines else None,
                      line_lift=LIFT_REL * edge)
        self.blocks = None if self._host_side else SurfaceBlocks(**blocks)
        if self._host_side:
            self.scene.make_blocks(blocks)
        self._known: dict[int, int] = {}  # body -> the store stamp of the surface the blocks hold
        self.scene.update_surfaces({"floor": self._floor})  # the first block: the viewer draws it alone
        self.refresh()

    def _refresh_surfaces(self) -> None:
        """Send what a fracture changed to the blocks (here, or in the drawing process)."""
        w = self.world
        changes = surface_changes(w, self._known)
        if len(self.looks) < len(w.materials):  # a material added after the start (the viewer's ball)
            self.looks = changes.looks = material_looks(w)
        self._known = {b: self._known[b] for b in changes.bodies if b in self._known}
        self._known.update(zip(changes.changed, changes.stamps))
        if self._host_side:
            self.scene.apply_surface_changes(changes)
        else:
            self.blocks.apply(changes, self.scene)

    def refresh(self) -> None:
        """Bring surfaces (when fracture changed them) and poses up to date."""
        w = self.world
        if "rigid" in w.stages:
            if w.surface_version != self._version:
                self._refresh_surfaces()
                self._version = w.surface_version
            if self._host_side:  # read through the stores' download kernels (render/draw_process.py)
                st = w.rigid.body_state()
                self.scene.set_poses(st.x, st.q, w.rigid.ref_coms())
                if "debris" in w.stages:
                    d = w.debris.state()
                    self.scene.set_particles(d["x"], d["r"], debris_color(w))
            else:
                s = w.rigid._s
                self.scene.copy_poses_from(s.body_x, s.body_q, s.body_ref_com, w.rigid.n_bodies)
                if "debris" in w.stages:
                    self.scene.copy_particles_from(w.debris.debris_x, w.debris.debris_r, w.debris.count,
                                                   debris_color(w))
        else:  # elastic scenes: the particles themselves
            x = w.elastic.positions()
            colors = np.where(w.elastic_fixed[:, None], [[0.35, 0.35, 0.4]], [[0.85, 0.55, 0.25]])
            self.scene.set_particles(x, w.particles.radius * 1.2, colors)
        self.scene.update()

    def release(self) -> None:
        self.scene.release()


class HeadlessSession:
    """The frames of a World: `draw()` brings the view up to date, moves the following camera and
    renders (None with the 'none' renderer); with an output folder, `write_frame()` also writes one
    PNG per frame (and a video). Without one (out=None) nothing is written: the figure sheet, the
    frame benchmark and the framing test draw frames in memory."""

    def __init__(self, world, kind: str, width: int, height: int, out: Path | None = None, video: str = "none",
                 colors: str = "material", crack_lines: bool = True, drawing=None) -> None:
        if colors not in COLOR_MODES:
            raise ConfigError("--colors", colors, ", ".join(COLOR_MODES))
        self.drawing = drawing  # a started render.draw_process.DrawingProcess: it draws and writes the frames
        self.framing = FollowCamera(camera_for(world, width / height), width / height, floor_height(world),
                                    follow=world.cfg.camera.mode == "follow")
        self.camera = self.framing.camera
        self.frames = self.video = self.renderer = None
        self.report: dict = {}  # the drawing process's, once closed
        if drawing is not None:
            self.description = drawing.started()
            self.view = SceneView(world, colors, crack_lines, scene_factory=drawing.feed)
            drawing.send("camera", self.framing)
            drawing.send("warm")  # its renderer compiles while the simulation takes the first step
            return
        self.renderer = make_renderer(kind, width, height)  # first: a renderer that cannot start allocates nothing
        self.description = self.renderer.message
        self.view = SceneView(world, colors, crack_lines)
        if out is not None:
            self.frames = PngSequenceWriter(Path(out) / "frames")
            self.video = make_writer(video, out, fps=world.cfg.scene.fps, stem=world.cfg.scene.name)

    def draw(self) -> np.ndarray | None:
        self.view.refresh()
        self.camera = self.framing.update(*self.view.scene.body_bounds())
        return self.renderer.render(self.view.scene, self.camera)

    def write_frame(self) -> np.ndarray | None:
        """Draw the frame and write it (the drawing process's image is not returned)."""
        if self.drawing is not None:
            self.view.refresh()
            self.drawing.draw()
            return None
        img = self.draw()
        self.frames.write(img)
        if self.video is not None:
            self.video.write(img)
        return img

    def close(self) -> None:
        if self.drawing is not None:
            self.report = self.drawing.close()
            return
        if self.video is not None:
            self.video.close()
        if self.frames is not None:
            self.frames.close()
        self.renderer.release()
        self.view.release()
