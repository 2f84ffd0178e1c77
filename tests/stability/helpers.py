"""Shared helpers of the stability suite: small scenes, energies, speeds and a momentum ledger.

Nothing here is a test. The scenes are dicts for `scenes.loader.scene_from_dict`, so a test can
change any value before validation (the same path as a scene file).
"""

from __future__ import annotations

import copy
import sys
from pathlib import Path

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
SCENE_DIR = ROOT / "scenes"
G = 9.81  # m/s^2

GLASS = {"model": "isotropic", "E": 7.0e10, "nu": 0.22}
STEEL = {"model": "isotropic", "E": 2.0e11, "nu": 0.3}


def scene_raw(name: str) -> dict:
    """The raw dict of a scene file in scenes/ (to modify before scene_from_dict)."""
    return tomllib.loads((SCENE_DIR / f"{name}.toml").read_text())


def material(name: str, stiffness: dict, density: float = 2500.0, **kw) -> dict:
    m = {"name": name, "density": density, "stiffness": dict(stiffness)}
    m.update(kw)
    return m


def pane_scene(speed: float, size=(0.2, 0.2, 0.008), resolution: float = 0.02, frames: int = 20,
               effects=("rigid", "fracture", "subdivision", "shatter"), static: bool = True,
               friction: float = 0.4, gravity=(0.0, -9.81, 0.0), ball_radius: float = 0.02,
               held_border: float = 0.02, kernel=None) -> dict:
    """A steel ball shot along -z at `speed` into a glass pane (the plane z = 0 is its mid-plane)."""
    return {
        "scene": {"name": "pane_test", "effects": list(effects), "frames": frames, "fps": 60.0, "substeps": 4,
                  "seed": 0, "gravity": list(gravity)},
        "materials": [
            material("glass", GLASS, 2500.0, tensile_strength=4.0e7, toughness=8.0, restitution=0.1,
                     friction=friction, cracks=4,
                     kernel=kernel or {"mode": "fixed", "support": 2.0, "axis_scale": [2.0, 2.0, 1.0]}),
            material("steel", STEEL, 7800.0, tensile_strength=5.0e8, toughness=1.0e4, restitution=0.3,
                     friction=friction),
        ],
        "objects": [
            {"name": "pane", "shape": {"type": "pane", "size": list(size)}, "material": "glass",
             "resolution": resolution, "position": [0.0, 0.3, 0.0], "static": static,
             "held_border": held_border if static else 0.0, "breakable": True},
            {"name": "ball", "shape": {"type": "sphere", "radius": ball_radius}, "material": "steel",
             "resolution": ball_radius * 0.6, "position": [0.01, 0.31, ball_radius + size[2] / 2 + 0.01],
             "velocity": [0.0, 0.0, -float(speed)], "breakable": False},
        ],
        "colliders": [{"type": "plane", "normal": [0.0, 1.0, 0.0], "friction": friction}],
    }


def body_energy(world, gravity=None) -> float:
    """J: kinetic energy of the dynamic bodies plus the gravity potential of every alive body (static
    ones too: a held pane's shards are released with it), datum at the origin."""
    g = np.asarray(world.cfg.scene.gravity if gravity is None else gravity, dtype=np.float64)
    st = world.rigid.body_state()
    e = world.rigid.kinetic_energy(st)
    for b in np.flatnonzero(st.alive):
        e -= world.rigid.body_mass(int(b)) * float(g @ st.x[b])
    return float(e)


def sphere_speeds(world) -> np.ndarray:
    """(NS,) m/s: speed of every boundary sphere centre (v + w x r) of the alive dynamic bodies."""
    rig = world.rigid
    st = rig.body_state()
    if rig.n_spheres == 0:
        return np.zeros(0)
    _, _, body = rig.sphere_data()
    xw = rig.sphere_world(st)
    v = st.v[body] + np.cross(st.w[body], xw - st.x[body])
    ok = st.alive[body] & ~np.array([rig.body_is_static(int(b)) for b in range(rig.n_bodies)])[body]
    return np.linalg.norm(v[ok], axis=1)


def momentum(world, state=None) -> np.ndarray:
    """kg m/s: total linear momentum of the alive dynamic bodies."""
    st = world.rigid.body_state() if state is None else state
    p = np.zeros(3)
    for b in np.flatnonzero(st.alive):
        if not world.rigid.body_is_static(int(b)):
            p += world.rigid.body_mass(int(b)) * st.v[b]
    return p


class MomentumLedger:
    """Checks, step by step, that the momentum of the dynamic bodies changes only by what acts on them.

    Per rigid step (frictionless contacts, so that every contact impulse is normal and reported):
        P_after - P_before = sum_dynamic m g dt + sum_contacts lambda n ([a dynamic] - [b dynamic])
    (contacts between two dynamic bodies cancel; the rest are the impulses of static bodies and
    colliders). Per fracture event (between frames):
        P_after - P_before = - momentum of the shattered particles taken out of the simulation
    (their velocity from the parent's velocity field v + w x r at the split) + momentum of new
    dynamic children of static parents (zero: they start at rest).
    `residual` keeps the largest mismatch of each kind (kg m/s); `scale` the largest |P| or impulse.
    """

    def __init__(self, world) -> None:
        self.world = world
        self.rigid = world.rigid
        self.step_residual = 0.0
        self.fracture_residual = 0.0
        self.scale = 0.0
        self.external = np.zeros(3)  # kg m/s: accumulated impulse of static bodies, colliders, gravity
        self.debris_momentum = np.zeros(3)  # kg m/s: carried away by removed debris
        self._inner = self.rigid.step
        self.rigid.step = self._step
        self._last_state = None
        self._events = len(world.events)  # fracture events already booked

    def _dynamic(self) -> np.ndarray:
        return np.array([not self.rigid.body_is_static(b) for b in range(self.rigid.n_bodies)], dtype=bool)

    def _step(self, dt: float, split: bool = True, free: bool = False) -> None:
        rig = self.rigid
        st0 = rig.body_state()
        p0 = momentum(self.world, st0)
        self._inner(dt, split, free)
        st1 = rig.body_state()
        p1 = momentum(self.world, st1)
        dyn = self._dynamic()
        # gravity acts on the dynamic bodies the step integrated: not those asleep before and after
        moved = st0.alive & dyn[: len(st0.alive)] & ~(st0.asleep & st1.asleep[: len(st0.alive)])
        g = np.asarray(rig.config.gravity, dtype=np.float64)
        grav = sum((rig.body_mass(int(b)) * g * dt for b in np.flatnonzero(moved)), np.zeros(3))
        ev = rig.contact_events()
        sa = np.where(ev.body_a >= 0, dyn[np.maximum(ev.body_a, 0)], False).astype(float)
        sb = np.where(ev.body_b >= 0, dyn[np.maximum(ev.body_b, 0)], False).astype(float)
        ext = grav + ((ev.normal_impulse * (sa - sb))[:, None] * ev.normal).sum(0)
        self.external += ext
        self.step_residual = max(self.step_residual, float(np.abs(p1 - p0 - ext).max()))
        self.scale = max(self.scale, float(np.abs(p0).max()), float(np.abs(ev.normal_impulse).max(initial=0.0)))
        self._last_state = st1

    def frame(self) -> None:
        """Step one frame of the world and check the fracture part of the balance."""
        from rigid.quat import quat_to_matrix

        w = self.world
        n0 = len(w.particles)
        body0 = w.particles.body.copy()
        w.step_frame()
        st = self._last_state  # the state the split used (end of the frame's last rigid step)
        if st is None:
            return
        ps = w.particles
        was = np.full(len(ps), -1, dtype=np.int64)
        was[:n0] = body0
        kids = np.arange(n0, len(ps))
        was[kids] = body0[ps.parent[kids]]  # children of this event: their parent's body (parents are physical)
        gone = (ps.body == -1) & (was >= 0)
        p_debris = np.zeros(3)
        for b in np.unique(was[gone]):
            if self.rigid.body_is_static(int(b)):
                continue  # a static parent's debris had no velocity
            sel = np.flatnonzero(gone & (was == b))
            R = quat_to_matrix(st.q[b])
            xw = (ps.centroid[sel] - self.rigid.body_ref_com(int(b))) @ R.T + st.x[b]
            v = st.v[b] + np.cross(st.w[b], xw - st.x[b])
            p_debris += (ps.mass[sel][:, None] * v).sum(0)
        self.debris_momentum += p_debris
        p_before = momentum(w, st)  # bodies alive at the split (the parents among them)
        p_after = momentum(w)
        # a striker let through the hole it shattered (sim/perforation.py) changes the bodies' momentum
        # by what the event records: from the support of a held body, or from the debris it sweeps
        p_perf = sum((np.asarray(e["perforation"]["bodies_momentum"]) for e in w.events[self._events:]
                      if e.get("perforation")), np.zeros(3))
        self._events = len(w.events)
        self.fracture_residual = max(self.fracture_residual,
                                     float(np.abs(p_after - (p_before - p_debris + p_perf)).max()))

    def release(self) -> None:
        self.rigid.step = self._inner


def deep(d: dict) -> dict:
    return copy.deepcopy(d)
