"""The bodies' surface blocks of a RenderScene, rebuilt for the bodies a fracture changed.

Two halves, so that the second can run in a drawing process (render/draw_process.py):
`surface_changes(world, known)` reads from the World what changed (the live bodies, the changed
ones' stamps and their particles, taken from the particle store: nothing of the other bodies), and
`SurfaceBlocks.apply(changes, scene)`, which needs no World, turns that into blocks: closed surfaces
(geometry.surface.fragment_surfaces), faces in their material's look with crack faces in its crack
shade (`colors="material"`) or one palette colour per body (`colors="fragments"`), and the crack
lines where crack faces meet the outer surface (render/crack_lines.py). A face is a crack face when
it does not lie on the objects' surface at rest (geometry.surface.RestSurface); the answer is cached
per tet face, a body's crack lines until a fracture changes the body.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.surface import RestSurface
from render.crack_lines import LINE_DARK, line_color, ribbons
from render.looks import CRACK_GREY
from render.scene_data import MeshPart, body_palette


@dataclass
class SurfaceChanges:
    """What changed in the bodies' surfaces since the stamps a consumer knows (picklable)."""

    bodies: list  # live bodies, in id order
    changed: list  # those whose particles changed (or are new)
    stamps: list  # the particle store's stamp of each changed body
    ids: np.ndarray | None  # store ids of the taken particles (None when nothing changed)
    particles: object = None  # a ParticleSet holding the changed bodies' particles (rows `ids` of the store)
    looks: list | None = None  # every material's look, when they changed (the viewer's added ball)


def surface_changes(world, known: dict) -> SurfaceChanges:
    """The live bodies and the particles of those whose store stamp differs from `known` (body ->
    stamp): taken from the store, or, at a consumer's first refresh (`known` empty) where the store's
    whole content is on the host already (the build keeps it), that copy (the take kernels then
    compile in the waits for drawn frames, sim/warm_up.py, not before the first frame)."""
    store = world.store
    count, _ = store.body_totals(max(store.body_stamp, default=-1) + 1)
    bodies = np.flatnonzero(count > 0).tolist()
    changed = [b for b in bodies if known.get(b) != store.body_stamp[b]]
    ids = ps = None
    if changed and not known and (ps := store.kept_host()) is not None:
        ids = np.arange(len(ps), dtype=np.int64)
    elif changed:
        ids, ps, _, _ = store.take_bodies(changed)
    return SurfaceChanges(bodies, changed, [store.body_stamp[b] for b in changed], ids, ps)


class SurfaceCache:
    """Fragment surfaces rebuilt only for the bodies a fracture changed. A body's closed surface
    (geometry.surface.fragment_surfaces, which treats every label on its own) depends only on its
    alive particles and their links; the particle store stamps every body it writes
    (ParticleStore.body_stamp), and the particles of the changed bodies alone are taken from it, so a
    fracture event copies nothing of the other bodies to the host. `surfaces(world)` equals
    `world_surfaces(world)` (tested)."""

    def __init__(self) -> None:
        self._bodies: dict[int, tuple] = {}  # body -> (stamp, verts, faces, face_id, face_material)

    def apply(self, changes: SurfaceChanges) -> list[int]:
        """Rebuild the changed bodies' meshes; returns the live bodies in id order."""
        from geometry.surface import fragment_surfaces

        live = set(changes.bodies)
        self._bodies = {b: v for b, v in self._bodies.items() if b in live}
        if changes.changed:
            ps, changed = changes.particles, changes.changed
            labels = np.where(ps.alive & np.isin(ps.body, changed), ps.body, -1).astype(np.int64)
            mesh = fragment_surfaces(ps, labels)
            row = mesh.face_id // 4
            face_id = changes.ids[row] * 4 + mesh.face_id % 4  # store ids, as the whole-world surfaces give them
            for b, stamp in zip(changed, changes.stamps):
                on = mesh.face_label == b
                used, inv = np.unique(mesh.faces[on], return_inverse=True)
                self._bodies[b] = (stamp, mesh.verts[used], inv.reshape(-1, 3), face_id[on], ps.material[row[on]])
        return list(changes.bodies)

    def update(self, world) -> list[int]:
        """`apply` to what changed in `world` since the last update."""
        return self.apply(surface_changes(world, {b: v[0] for b, v in self._bodies.items()}))

    def body_ids(self):
        """The bodies whose meshes are held."""
        return self._bodies.keys()

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


class SurfaceBlocks:
    """A RenderScene's body blocks from `SurfaceChanges` (module doc): rest (T, 3, 3) m, the objects'
    surface at rest, and rest_ids (T,) its tet face ids (None: not known); looks, one per material id;
    tol m, the on-surface distance of an outer face; line_width, line_lift m, the crack lines' ribbons
    (None: no crack lines)."""

    def __init__(self, rest: np.ndarray, looks: list, colors: str, tol: float, line_width: float | None,
                 line_lift: float, rest_ids: np.ndarray | None = None) -> None:
        self._rest = RestSurface(rest)
        self.looks = looks
        self.colors = colors
        self._tol = tol
        self.crack_lines = line_width is not None
        self._line_width, self._line_lift = line_width, line_lift
        self._outer = np.zeros(0, dtype=np.int8)  # per tet face (particle * 4 + k): -1 unknown, 0 crack, 1 outer
        if rest_ids is not None and len(rest_ids):
            # a face of the rest surface lies on it: known without the search (Pots' first blocks, 0.27 s)
            self._outer = np.full(int(rest_ids.max()) + 1, -1, dtype=np.int8)
            self._outer[rest_ids] = 1
        self._surfaces = SurfaceCache()
        self._ribbons: dict[int, tuple] = {}  # body -> its crack lines' (verts, faces, the face each lies on)

    def apply(self, changes: SurfaceChanges, scene) -> None:
        """Write the blocks of the bodies a fracture changed or made, drop those of bodies gone."""
        if changes.looks is not None:
            self.looks = changes.looks
        held = list(self._surfaces.body_ids())  # the bodies whose blocks the scene holds
        live = set(self._surfaces.apply(changes))
        gone = [b for b in held if b not in live]
        for b in gone:
            self._ribbons.pop(b, None)
        self._classify(changes.changed)
        changed = {b: self._body_parts(b) for b in changes.changed}  # new stamps: new blocks
        scene.update_surfaces(changed, drop=gone)

    def _classify(self, bodies: list) -> None:
        """Whether the faces of `bodies` not classified yet lie on the rest surface, in one search for
        all of them instead of one per body (glass_r5's event: the search 28-40 -> 18-26 ms of the
        drawing process's 40-70 ms for the event's changes, session 38). A face's answer depends on it
        alone; a tet face split between bodies takes the first body's piece, as one search per body in
        this order gives."""
        if not bodies:
            return
        meshes = [self._surfaces.body_mesh(b) for b in bodies]
        offsets = np.cumsum([0] + [len(m[1]) for m in meshes[:-1]])
        verts = np.concatenate([m[1] for m in meshes])
        faces = np.concatenate([m[2] + off for m, off in zip(meshes, offsets)])
        self.outer_faces(np.concatenate([m[3] for m in meshes]), verts, faces)

    def outer_faces(self, face_id: np.ndarray, verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
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
        _, v, f, fid = self._surfaces.body_mesh(body)
        mat = self._surfaces.body_face_material(body)
        outer = self.outer_faces(fid, v, f)
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
            # made anew: blocks are only rebuilt for a body whose surface changed
            rv, rf, on_face = self._ribbons[body] = ribbons(v, f, outer, self._line_width, self._line_lift)
            if len(rf):
                if self.colors == "fragments":  # light palette colours: the dark line
                    line = np.broadcast_to(LINE_DARK, (len(rf), 3))
                else:
                    line = np.array([line_color(lk.color, lk.opacity) for lk in self.looks])[mat[on_face]]
                parts.append(MeshPart(rv, rf, body=body, colors=line, color_per="face", roughness=1.0, opacity=1.0))
        return parts
