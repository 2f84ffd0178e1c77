"""Headless frames of a World: surfaces from the fragment tets, poses from the rigid store, a
renderer (the rasteriser by default, or GGUI), the following camera (render/framing.py), and the
PNG and video writers (DESIGN.md section 7).

Surfaces are rebuilt only when fracture changed them (`World.surface_version`), and then only for the
bodies it changed: each body is one block of the render buffers (RenderScene.update_surfaces), coloured
by each material's look with crack faces in its crack shade (`SceneView`); every frame one kernel moves
them by the body poses, read straight from the rigid store's fields.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import ConfigError
from geometry.surface import RestSurface
from render.camera import Camera
from render.crack_lines import LIFT_REL, LINE_DARK, LINE_WIDTH_REL, line_color, ribbons
from render.framing import FollowCamera
from render.looks import CRACK_GREY, material_look
from render.primitives import ground_quad
from render.scene_data import Lighting, MeshPart, RenderScene, body_palette
from render.select import make_renderer
from render.writers import PngSequenceWriter, make_writer

FLOOR_COLOR = (0.55, 0.55, 0.58)


def world_surfaces(world):
    """Closed surfaces of every body (labels = body ids), from the alive tet particles."""
    from geometry.surface import fragment_surfaces

    ps = world.particles
    labels = np.where(ps.alive, ps.body, -1).astype(np.int64)
    return fragment_surfaces(ps, labels)


class SurfaceCache:
    """Fragment surfaces rebuilt only for the bodies a fracture changed. A body's closed surface
    (geometry.surface.fragment_surfaces, which treats every label on its own) depends only on its
    alive particles and their links; the particle store stamps every body it writes
    (ParticleStore.body_stamp), and the particles of the changed bodies alone are taken from it, so a
    fracture event copies nothing of the other bodies to the host. `surfaces(world)` equals
    `world_surfaces(world)` (tested)."""

    def __init__(self) -> None:
        self._bodies: dict[int, tuple] = {}  # body -> (stamp, verts, faces, face_id, face_material)

    def update(self, world) -> list[int]:
        """Rebuild the changed bodies' meshes; returns the live bodies in id order."""
        from geometry.surface import fragment_surfaces

        store = world.store
        count, _ = store.body_totals(max(store.body_stamp, default=-1) + 1)
        bodies = np.flatnonzero(count > 0).tolist()
        changed = [b for b in bodies if self._bodies.get(b, (None,))[0] != store.body_stamp[b]]
        self._bodies = {b: v for b, v in self._bodies.items() if count[b] > 0}
        if changed:
            ids, ps, _, _ = store.take_bodies(changed)
            labels = np.where(ps.alive & np.isin(ps.body, changed), ps.body, -1).astype(np.int64)
            mesh = fragment_surfaces(ps, labels)
            row = mesh.face_id // 4
            face_id = ids[row] * 4 + mesh.face_id % 4  # store ids, as the whole-world surfaces give them
            for b in changed:
                on = mesh.face_label == b
                used, inv = np.unique(mesh.faces[on], return_inverse=True)
                self._bodies[b] = (store.body_stamp[b], mesh.verts[used], inv.reshape(-1, 3), face_id[on],
                                   ps.material[row[on]])
        return bodies

    def body_mesh(self, body: int) -> tuple:
        """(stamp, verts (V, 3) m reference frame, faces (F, 3), face ids) of a live body after `update`."""
        return self._bodies[body][:4]

    def body_face_material(self, body: int) -> np.ndarray:
        """(F,) material id of each face of a live body's mesh after `update`."""
        return self._bodies[body][4]

    def surfaces(self, world):
        """The whole world's mesh from the per-body cache (bodies in id order): what `world_surfaces`
        gives, without rebuilding the unchanged bodies (tests compare the two)."""
        from geometry.surface import SurfaceMesh

        verts, faces, face_id, vlab, flab = [], [], [], [], []
        offset = 0
        for b in self.update(world):
            _, v, f, fid, _ = self._bodies[b]
            verts.append(v)
            faces.append(f + offset)
            face_id.append(fid)
            vlab.append(np.full(len(v), b, np.int64))
            flab.append(np.full(len(f), b, np.int64))
            offset += len(v)
        if not verts:
            e = np.zeros(0, np.int64)
            return SurfaceMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), e, e, face_id=e)
        return SurfaceMesh(verts=np.concatenate(verts), faces=np.concatenate(faces), face_label=np.concatenate(flab),
                           vert_label=np.concatenate(vlab), face_id=np.concatenate(face_id))


def rest_surface(world) -> np.ndarray:
    """(T, 3, 3) m: the objects' surface before anything broke, in the reference frame: the built
    tets' faces that had no face neighbour (World.rest_open_faces)."""
    from geometry.subdivision import face_points

    p, k = np.nonzero(world.rest_open_faces)
    return face_points(world.particles.rest_verts[p])[np.arange(len(p)), k]


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
    """The renderable state of a World, kept in step with it (shared by headless runs and the viewer).

    Colours: `colors="material"` draws each face in its material's look (render/looks.py) and the faces
    that cracks created in the look's crack shade; `colors="fragments"` gives every body its own
    palette colour (crack faces a shade of it). A face is a crack face when it does not lie on the
    objects' surface at rest (geometry.surface.RestSurface); the answer is cached per tet face.
    `crack_lines`: where a crack face meets the outer surface, a thin line (render/crack_lines.py),
    so that cracks show where the pieces stay together (a held pane's sectors, a crack that did not
    separate); its geometry is cached per body until a fracture changes the body."""

    def __init__(self, world, colors: str = "material", crack_lines: bool = True, scene_factory=RenderScene) -> None:
        if colors not in COLOR_MODES:
            raise ConfigError("--colors", colors, ", ".join(COLOR_MODES))
        self.world = world
        self.colors = colors
        # the objects' surface at rest, indexed once: asked after every fracture event
        self._rest = RestSurface(rest_surface(world) if "rigid" in world.stages else np.zeros((0, 3, 3)))
        rest = self._rest.tris
        # room for the crack faces and debris of the first events, and a pose for every body the rigid
        # store can hold: a larger buffer is a new Taichi field, and the render kernels that read it
        # recompile (about 2 s for the surfaces; Pots' pose buffer grew past 64 and 128 bodies, 0.1-0.2 s)
        self.scene = scene_factory(tri_capacity=SURFACE_HEADROOM * len(rest) + 2,
                                   body_capacity=world.rigid.capacity["bodies"] if "rigid" in world.stages else 0,
                                   particle_capacity=world.physical_count if "debris" in world.stages else 0,
                                   lighting=Lighting.studio())
        self._version = -1
        self._floor = []
        for col in world.cfg.colliders:
            if col.type == "plane" and abs(col.normal[1]) > 0.99:
                v, f = ground_quad(height=col.point[1], half_size=2.0)
                self._floor.append(MeshPart(v, f, body=-1, colors=FLOOR_COLOR, roughness=0.9))
        self.looks = material_looks(world)
        size = float(np.ptp(rest.reshape(-1, 3), axis=0).max()) if len(rest) else 1.0
        self._tol = ON_SURFACE_REL * max(size, 1e-3)  # m: on-surface distance for outer faces
        self._outer = np.zeros(0, dtype=np.int8)  # per tet face (particle * 4 + k): -1 unknown, 0 crack, 1 outer
        self._surfaces = SurfaceCache()
        self.crack_lines = crack_lines
        edge = np.median(np.linalg.norm(rest - np.roll(rest, 1, axis=1), axis=2)) if len(rest) else 0.0
        self._line_width, self._line_lift = LINE_WIDTH_REL * edge, LIFT_REL * edge  # m
        self._ribbons: dict[int, tuple] = {}  # body -> (stamp, verts, faces, the outer face of each triangle)
        self._stamps: dict[int, int] = {}  # body -> the stamp of the surface block the scene holds
        self.scene.update_surfaces({"floor": self._floor})  # the first block: the viewer draws it alone
        self.refresh()

    def _outer_faces(self, face_id: np.ndarray, verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """(F,) bool: the faces (tet face ids, vertices, faces) lying on the objects' rest surface (the
        rest are crack faces)."""
        fid = face_id
        if len(fid) and fid.max() >= len(self._outer):
            grown = np.full(max(int(fid.max()) + 1, 2 * len(self._outer)), -1, dtype=np.int8)
            grown[: len(self._outer)] = self._outer
            self._outer = grown
        todo = np.flatnonzero(self._outer[fid] < 0)
        if todo.size:
            first = np.unique(fid[todo], return_index=True)[1]  # split faces share their tet face
            rows = todo[first]
            self._outer[fid[rows]] = self._rest.covers(verts[faces[rows]], self._tol)
        return self._outer[fid] == 1

    def _body_parts(self, body: int) -> list[MeshPart]:
        """A body's surface block: one part per material (its roughness and opacity), faces coloured by
        look and crack, and its crack lines."""
        w = self.world
        if len(self.looks) < len(w.materials):  # a material added after the start (the viewer's ball)
            self.looks = material_looks(w)
        stamp, v, f, fid = self._surfaces.body_mesh(body)
        mat = self._surfaces.body_face_material(body)
        outer = self._outer_faces(fid, v, f)
        if self.colors == "fragments":
            base = np.broadcast_to(body_palette(body + 1)[body], (len(f), 3))
            crack = 0.6 * base + 0.4 * np.asarray(CRACK_GREY)
        else:
            base = np.array([lk.color for lk in self.looks])[mat]
            crack = np.array([lk.crack() for lk in self.looks])[mat]
        color = np.where(outer[:, None], base, crack)
        parts = []
        for m in np.unique(mat):
            sel = mat == m
            look = self.looks[int(m)]
            parts.append(MeshPart(v, f[sel], body=body, colors=color[sel], color_per="face",
                                  roughness=look.roughness, opacity=look.opacity))
        if self.crack_lines:
            hit = self._ribbons.get(body)
            if hit is None or hit[0] != stamp:
                hit = self._ribbons[body] = (stamp, *ribbons(v, f, outer, self._line_width, self._line_lift))
            _, rv, rf, on_face = hit
            if len(rf):
                if self.colors == "fragments":  # light palette colours: the dark line
                    line = np.broadcast_to(LINE_DARK, (len(rf), 3))
                else:
                    line = np.array([line_color(lk.color, lk.opacity) for lk in self.looks])[mat[on_face]]
                parts.append(MeshPart(rv, rf, body=body, colors=line, color_per="face", roughness=1.0, opacity=1.0))
        return parts

    def _refresh_surfaces(self) -> None:
        """Write the blocks of the bodies a fracture changed or made, drop those of bodies gone."""
        bodies = self._surfaces.update(self.world)
        live = set(bodies)
        gone = [b for b in self._stamps if b not in live]
        for b in gone:
            del self._stamps[b]
            self._ribbons.pop(b, None)
        changed = {}
        for b in bodies:
            stamp = self._surfaces.body_mesh(b)[0]
            if self._stamps.get(b) != stamp:
                changed[b] = self._body_parts(b)
                self._stamps[b] = stamp
        self.scene.update_surfaces(changed, drop=gone)

    def refresh(self) -> None:
        """Bring surfaces (when fracture changed them) and poses up to date."""
        w = self.world
        if "rigid" in w.stages:
            if w.surface_version != self._version:
                self._refresh_surfaces()
                self._version = w.surface_version
            if getattr(self.scene, "host_side", False):  # a SceneFeed (render/draw_process.py): host arrays
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
