"""Strikes and crack previews on a World (Sect. 4.2, Algorithm 1), shared by the Python API and the
viewer.

* A strike (`strike`) is a normal impact of a rigid flat anvil (other = -1: the first collider's
  Young's modulus, infinite mass and radius) on a breakable body at a surface point, applied between
  frames: `sim.fracture_stage.fracture_body` analyses it (Algorithm 1), cuts, shatters and splits.
  The striker's velocity gives the speed (its norm) and the direction of the blow; the analysis takes
  the struck surface's own normal near that direction (sim.struck_surface.surface_frame).
* A preview (`preview`) runs the same analysis and applies nothing: Algorithm 1's groups, the crack
  discs in the world frame, the group stresses, the shatter radius and the speed at which the first
  group would fire.

Rest data are in the reference frame (the scene at t = 0); a body maps X to `R(q) (X - ref_com) + x`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ConfigError, SandboxError
from sim.export_frames import body_frames


# ----------------------------------------------------------------------------- frames
def to_world(frames, body, X) -> np.ndarray:
    """Reference points X (..., 3) of `body` (int or (...,) ids) -> world (m)."""
    R, x, com = frames
    X = np.asarray(X, dtype=np.float64)
    b = np.asarray(body)
    return np.einsum("...ij,...j->...i", R[b], X - com[b]) + x[b]


def dir_to_world(frames, body, d) -> np.ndarray:
    R = frames[0]
    return np.einsum("...ij,...j->...i", R[np.asarray(body)], np.asarray(d, dtype=np.float64))


def to_reference(frames, body: int, p, d=None):
    """World point p (and direction d) -> reference frame of `body`."""
    R, x, com = frames
    pr = R[body].T @ (np.asarray(p, dtype=np.float64) - x[body]) + com[body]
    return pr if d is None else (pr, R[body].T @ np.asarray(d, dtype=np.float64))


def breakable(world, body: int) -> bool:
    """True for a live, breakable body of the World (what a strike may break)."""
    if "rigid" not in world.stages:
        return False
    info = getattr(world, "bodies", {}).get(int(body))
    return info is not None and info.breakable and bool(world.rigid.body_state().alive[int(body)])


# ----------------------------------------------------------------------------- striking
def strike_impact(world, body: int, point, velocity, key: str = "strike") -> dict:
    """The impact dict of sim.fracture_stage for a rigid anvil moving at `velocity` (m/s, world) that
    meets `body` at `point` (m, world): speed |v|, inward normal v / |v|, impulse m |v| (kg m/s, for
    the record) and `key`. Bad arguments raise ConfigError naming `key`; a point off the body raises it
    in the analysis (sim.fracture_stage.analyse), which has the body's particles at hand."""
    p = np.asarray(point, dtype=np.float64).reshape(-1)
    v = np.asarray(velocity, dtype=np.float64).reshape(-1)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ConfigError(f"{key}.point", np.asarray(point).tolist(), "3 finite coordinates (m)")
    speed = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else float("nan")
    if not speed > 0.0:
        raise ConfigError(f"{key}.velocity", np.asarray(velocity).tolist(), "3 finite components, speed > 0 m/s")
    if not breakable(world, body):
        raise ConfigError(f"{key}.body", body, f"a live breakable body ({_breakable_ids(world)})")
    return dict(other=-1, speed=speed, point=p.copy(), normal=v / speed, impulse=world.rigid.body_mass(body) * speed,
                key=key)


def _breakable_ids(world) -> str:
    ids = [b for b in sorted(getattr(world, "bodies", {})) if breakable(world, b)]
    return "bodies " + ", ".join(map(str, ids)) if ids else "none in this scene"


def strike(world, body: int, point, velocity, key: str = "strike") -> dict | None:
    """Apply a strike now (between frames): analyse, cut, shatter and split. Returns the event record
    (also appended to world.events) or None when no group of Algorithm 1 fired."""
    from sim.fracture_stage import fracture_body

    record = fracture_body(world, body, strike_impact(world, body, point, velocity, key))
    if record is not None:
        record["strike"] = True
        world.events.append(record)
        world.surface_version += 1
    return record


# ----------------------------------------------------------------------------- preview
@dataclass
class CrackShape:
    """A crack disc in the world frame, ready to draw."""

    point: np.ndarray  # (3,) m: disc centre (the impact point)
    normal: np.ndarray  # (3,) -: crack plane normal
    r_outer: float  # m
    side: np.ndarray | None  # (3,) -: half-disc side in the plane, None = full disc
    r_inner: float  # m: shatter radius carried by the crack


@dataclass
class Preview:
    """A hypothetical strike: Algorithm 1 at a surface point, nothing applied.

    `analysis` is the full sph.cracks.ImpactAnalysis in the body's reference frame: per group its
    members, mean strain and stress (Pa), tensile principal stresses and directions, energy (J), Eq. 11
    radius and whether it fired; the Hertz contact; the shatter radius (m) and U_limit (J/m^3)."""

    body: int
    point: np.ndarray  # (3,) m world
    normal: np.ndarray  # (3,) - inward unit normal, world
    speed: float  # m/s
    analysis: object  # sph.cracks.ImpactAnalysis (reference frame of the body)
    particle_ids: np.ndarray  # (M,) indices into world.particles of the analysed set N_p
    particle_x: np.ndarray  # (M, 3) m world positions of the analysed particles
    group: np.ndarray  # (M,) group of each analysed particle
    cracks: list  # [CrackShape] world frame
    r_inner: float  # m: shatter radius (0 unless a group fired)
    threshold_speed: float  # m/s: speed at which the first group would fire (inf: none)
    point_ref: np.ndarray = None  # (3,) m: the point in the body's reference frame
    normal_ref: np.ndarray = None  # (3,) -: the inward normal in the body's reference frame

    @property
    def fired(self) -> np.ndarray:
        """(N,) bool: the groups whose peak tension exceeds the tensile strength (Rankine)."""
        return np.asarray(self.analysis.fired)

    @property
    def principal_stress(self) -> np.ndarray:
        """(N, 3) Pa: principal values of each group's MEAN tensile stress, largest first (its
        eigenvector is the crack normal; the Rankine test uses `peak_tension`)."""
        return np.asarray(self.analysis.principal_stress)

    @property
    def peak_tension(self) -> np.ndarray:
        """(N,) Pa: the largest tensile principal stress of any member of each group: a group fires
        when it exceeds the tensile strength (Rankine, a point criterion)."""
        return np.asarray(self.analysis.tension_per_newton) * self.analysis.hertz.force

    def refresh_world(self, world) -> None:
        """Move the world-frame shapes with the body's current pose (the analysis itself is kept)."""
        frames = body_frames(world)
        ps = world.particles
        self.point = to_world(frames, self.body, self.point_ref)
        self.normal = dir_to_world(frames, self.body, self.normal_ref)
        self.particle_x = to_world(frames, np.full(len(self.particle_ids), self.body), ps.centroid[self.particle_ids])
        self.cracks = crack_shapes(frames, self.body, self.analysis.cracks)


def crack_shapes(frames, body: int, cracks) -> list:
    """World-frame CrackShapes of reference-frame cracks (geometry.cutting.Crack) of `body`."""
    out = []
    for c in cracks:
        side = None if c.side is None else dir_to_world(frames, body, c.side)
        out.append(CrackShape(point=to_world(frames, body, c.point), normal=dir_to_world(frames, body, c.normal),
                              r_outer=float(c.r_outer), side=side, r_inner=float(c.r_inner)))
    return out


def preview(world, body: int, point, velocity, key: str = "preview") -> Preview:
    """Run the crack analysis only (sim.fracture_stage.analyse) for a strike of `body` at `point`
    (m, world) by an anvil moving at `velocity` (m/s, world); nothing is applied."""
    from sim.fracture_stage import analyse, analysed_rows, take_body
    from sph.cracks import threshold_speed

    impact = strike_impact(world, body, point, velocity, key)
    taken = take_body(world, body)
    res = analyse(world, body, impact, taken)
    rows = analysed_rows(taken.particles, body)[np.asarray(res.particles, dtype=np.int64)]
    ids = taken.ids[rows]
    frames = body_frames(world)
    p_ref, n_ref = to_reference(frames, body, impact["point"], impact["normal"])
    try:
        v_th = float(threshold_speed(res, None))
    except (SandboxError, ValueError, ZeroDivisionError, FloatingPointError):  # a diagnostic only
        v_th = math.inf
    return Preview(body=body, point=impact["point"], normal=impact["normal"], speed=impact["speed"], analysis=res,
                   particle_ids=ids,
                   particle_x=to_world(frames, np.full(len(ids), body), taken.particles.centroid[rows]),
                   group=np.asarray(res.group, dtype=np.int64), cracks=crack_shapes(frames, body, res.cracks),
                   r_inner=float(res.r_inner) if res.cracks else 0.0, threshold_speed=v_th, point_ref=p_ref,
                   normal_ref=n_ref)
