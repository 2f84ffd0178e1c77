"""Headless frames of a World: surfaces from the fragment tets, poses from the rigid store, a
renderer (GGUI or the rasteriser), and the PNG and video writers (DESIGN.md section 7).

Surfaces are rebuilt only when fracture changed them (`World.surface_version`); every frame one
kernel moves them by the body poses, read straight from the rigid store's fields.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from render.camera import Camera
from render.framing import FollowCamera
from render.primitives import ground_quad
from render.scene_data import Lighting, MeshPart, RenderScene, body_palette
from render.select import make_renderer
from render.writers import PngSequenceWriter, make_writer

FLOOR_COLOR = (0.55, 0.55, 0.58)
DEBRIS_COLOR = (0.78, 0.80, 0.84)  # shattered particles (the `debris` effect)


def world_surfaces(world):
    """Closed surfaces of every body (labels = body ids), from the alive tet particles."""
    from geometry.surface import fragment_surfaces

    ps = world.particles
    labels = np.where(ps.alive, ps.body, -1).astype(np.int64)
    return fragment_surfaces(ps, labels)


def camera_for(world, aspect: float) -> Camera:
    c = world.cfg.camera
    return Camera(eye=c.eye, target=c.target, fov_deg=c.fov)


def floor_height(world) -> float | None:
    """m: height of the lowest horizontal plane collider (the floor), None without one."""
    ys = [c.point[1] for c in world.cfg.colliders if c.type == "plane" and abs(c.normal[1]) > 0.99]
    return min(ys) if ys else None


class SceneView:
    """The renderable state of a World, kept in step with it (shared by headless runs and the viewer)."""

    def __init__(self, world) -> None:
        self.world = world
        self.scene = RenderScene(lighting=Lighting.studio())
        self._version = -1
        self._floor = []
        for col in world.cfg.colliders:
            if col.type == "plane" and abs(col.normal[1]) > 0.99:
                v, f = ground_quad(height=col.point[1], half_size=2.0)
                self._floor.append(MeshPart(v, f, body=-1, colors=FLOOR_COLOR))
        self.refresh()

    def refresh(self) -> None:
        """Bring surfaces (when fracture changed them) and poses up to date."""
        w = self.world
        if "rigid" in w.stages:
            if w.surface_version != self._version:
                mesh = world_surfaces(w)
                palette = body_palette(max(1, w.rigid.n_bodies))
                parts = list(self._floor)
                for label in np.unique(mesh.vert_label):
                    verts, faces = mesh.fragment(int(label))
                    parts.append(MeshPart(verts, faces, body=int(label), colors=tuple(palette[int(label)])))
                self.scene.set_surfaces(parts)
                self._version = w.surface_version
            s = w.rigid._s
            self.scene.copy_poses_from(s.body_x, s.body_q, s.body_ref_com, w.rigid.n_bodies)
            if "debris" in w.stages:
                self.scene.copy_particles_from(w.debris.debris_x, w.debris.debris_r, w.debris.count, DEBRIS_COLOR)
        else:  # elastic scenes: the particles themselves
            if self._version < 0:
                self.scene.set_surfaces(self._floor)
                self._version = 0
            x = w.elastic.positions()
            colors = np.where(w.elastic_fixed[:, None], [[0.35, 0.35, 0.4]], [[0.85, 0.55, 0.25]])
            self.scene.set_particles(x, w.particles.radius * 1.2, colors)
        self.scene.update()

    def release(self) -> None:
        self.scene.release()


class HeadlessSession:
    """Writes one PNG per frame (and a video) for a World."""

    def __init__(self, world, kind: str, width: int, height: int, out: Path, video: str) -> None:
        self.renderer = make_renderer(kind, width, height)
        self.description = self.renderer.message
        self.view = SceneView(world)
        self.framing = FollowCamera(camera_for(world, width / height), width / height, floor_height(world),
                                    follow=world.cfg.camera.mode == "follow")
        self.camera = self.framing.camera
        self.frames = PngSequenceWriter(Path(out) / "frames")
        self.video = make_writer(video, out, fps=world.cfg.scene.fps, stem=world.cfg.scene.name)

    def write_frame(self) -> np.ndarray:
        self.view.refresh()
        self.camera = self.framing.update(*self.view.scene.body_bounds())
        img = self.renderer.render(self.view.scene, self.camera)
        self.frames.write(img)
        if self.video is not None:
            self.video.write(img)
        return img

    def close(self) -> None:
        if self.video is not None:
            self.video.close()
        self.frames.close()
        self.renderer.release()
        self.view.release()
