"""Recording a run as an animation of rigid pieces, for the glTF and USD exports (DESIGN.md section 7).

Every body's closed surface (Sect. 6's fragment faces) is stored once per *piece*: a body's mesh
as long as its particles and links stay the same. A fracture that changes a body ends its piece
at that frame and starts new pieces for the body and for every fragment split off it, so a
fragment appears at the frame it is created and replaces its parent from then on. Between
changes a piece only moves: its rigid pose (translation, rotation) is sampled every frame.

A piece's vertices are in its body's frame: reference position minus the body's reference centre
of mass, so world = R local + x with the body's rotation R and position x (sim.export_frames).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Piece:
    """One body mesh over the frames it lives: the unit a glTF node or a USD prim animates."""

    body: int
    verts: np.ndarray  # (V, 3) float32 m: body frame
    faces: np.ndarray  # (F, 3) uint32
    color: tuple  # linear RGB in [0, 1] of the piece's material look
    opacity: float  # 1 opaque, < 1 see-through (glass)
    start: int  # first frame index it is shown
    end: int | None = None  # first frame index it is no longer shown (None: to the end)
    frames: list = field(default_factory=list)  # frame indices sampled
    translations: list = field(default_factory=list)  # (3,) m per sample
    rotations: list = field(default_factory=list)  # (4,) unit quaternion (x, y, z, w) per sample


def _quaternions_xyzw(rot: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(rot).as_quat()  # (x, y, z, w), glTF's and our order here


class AnimationRecorder:
    """Call `record(world, frame)` after every frame (and once before the first at frame 0)."""

    def __init__(self, world, fps: float) -> None:
        from render.session import material_looks
        from render.surface_blocks import SurfaceCache

        if "rigid" not in world.stages:
            from core.errors import ConfigError

            raise ConfigError("--export", "glb/usd", "a scene with the 'rigid' effect (pieces that move)")
        self.fps = float(fps)
        self.pieces: list[Piece] = []
        self.last_frame = 0
        self._open: dict[int, tuple[int, int]] = {}  # body -> (signature, piece index)
        self._cache = SurfaceCache()
        self._version = None
        self._looks = material_looks(world)

    def _body_materials(self, world, bodies: list[int]) -> dict[int, int]:
        """The most common material of each live body's particles: recorded by the World when it
        made the body (World.body_material); counted from the particles for a body it did not make
        (the viewer's shot ball)."""
        known = {b: world.body_material[b] for b in bodies if b in world.body_material}
        if len(known) == len(bodies):
            return known
        ps = world.particles
        for b in set(bodies) - set(known):
            mine = ps.alive & (ps.body == b)
            known[b] = int(np.bincount(ps.material[mine]).argmax()) if mine.any() else 0
        return known

    def _refresh(self, world, frame: int) -> None:
        from sim.export_frames import body_frames

        live = self._cache.update(world)
        _, _, com = body_frames(world)
        materials = self._body_materials(world, live)
        now = {}
        for b in live:
            sig, verts, faces, _ = self._cache.body_mesh(b)
            if len(faces) == 0:
                continue
            held = self._open.get(b)
            if held is not None and held[0] == sig:
                now[b] = held
                continue
            look = self._looks[materials.get(b, 0)]
            self.pieces.append(Piece(b, (verts - com[b]).astype(np.float32), faces.astype(np.uint32),
                                     tuple(look.color), float(look.opacity), start=frame))
            now[b] = (sig, len(self.pieces) - 1)
        for b, (_, k) in self._open.items():
            if now.get(b, (None, -1))[1] != k:
                self.pieces[k].end = frame
        self._open = now

    def record(self, world, frame: int) -> None:
        """Sample every live piece's pose at `frame` (index; time = frame / fps)."""
        from sim.export_frames import body_frames

        if world.surface_version != self._version:
            self._refresh(world, frame)
            self._version = world.surface_version
        rot, x, _ = body_frames(world)
        bodies = np.fromiter(self._open, dtype=np.int64, count=len(self._open))
        if len(bodies):
            quats = _quaternions_xyzw(rot[bodies])
            for b, q in zip(bodies.tolist(), quats):
                piece = self.pieces[self._open[b][1]]
                if piece.rotations and np.dot(piece.rotations[-1], q) < 0:
                    q = -q  # the same rotation on the near side: interpolation takes the short way
                piece.frames.append(frame)
                piece.translations.append(x[b].copy())
                piece.rotations.append(q)
        self.last_frame = frame

    def time(self, frame: int) -> float:
        """Seconds of frame index `frame`."""
        return frame / self.fps


__all__ = ["AnimationRecorder", "Piece"]
