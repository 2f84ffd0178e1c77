"""The rigid world: bodies made of boundary spheres, static colliders, and the impulse-based step.

A lightweight impulse-based integrator in Taichi, standing in for the commercial engine of the
paper (Sect. 6.1 used Newton Game Dynamics); collision runs on boundary particles only (Sect. 5.3).
The stages and their equations are described in `rigid.kernels`; conventions, parameters and the
operating envelope in docs/notes_rigid.md.

Body frame: a reference point X (tet rest vertex, metres) maps to world as
`x = R(q) (X - body_ref_com) + body_x`; quaternions are w-x-y-z; boundary spheres store
`bp_local = X_ref - body_ref_com`. At spawn q = identity and body_x = body_ref_com + offset.

Host side: fixed data (mass properties, spheres, colliders) is mirrored in numpy here and uploaded
when it changes; changing data (pose, velocity, sleep) lives in the fields and is read back on
demand. Bodies are appended and never re-numbered (a removed body keeps its id, alive = 0);
spheres are compacted when a body is removed. Adding or removing bodies and growing capacities
happen between steps only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from rigid import kernels as K
from rigid.mass import MassProperties
from rigid.quat import IDENTITY, quat_to_matrix
from rigid.store import acquire_store, recycle_store
from sim.errors import CapacityError, ConfigError
from sim.runtime import numpy_float


@dataclass
class RigidConfig:
    """Solver parameters (SI units). Defaults suit objects of 1 cm to 1 m at dt = 1/240 s."""

    gravity: tuple = (0.0, -9.81, 0.0)  # m/s^2
    substeps: int = 8  # -: solver substeps per step (contacts are found once per step)
    velocity_iterations: int = 4  # -: sequential-impulse passes per substep (even: symmetric sweeps)
    restitution_iterations: int = 2  # -: restitution passes per step
    position_iterations: int = 4  # -: split-impulse passes per step (even: symmetric sweeps)
    restitution_threshold_mps: float = 0.5  # m/s: closing speeds below this never bounce
    linear_slop_m: float = 2.0e-5  # m: penetration left uncorrected (keeps resting contacts warm)
    position_correction_rate: float = 0.2  # -: fraction of the penetration removed per step
    max_correction_speed_mps: float = 1.0  # m/s: cap of the pseudo velocity of the position correction
    speculative_margin_m: float = 2.0e-3  # m: contacts are created this far before touching
    linear_damping_per_s: float = 0.0  # 1/s: v <- v / (1 + c dt)
    angular_damping_per_s: float = 0.0  # 1/s: w <- w / (1 + c dt)
    max_speed_mps: float = 200.0  # m/s: linear speed clamp
    max_rotation_per_step_rad: float = 0.25 * math.pi  # rad: |w| dt clamp
    mass_ratio_cap: float = 4.0  # -: heavy-on-light contacts are solved as if at most this ratio (0 = off)
    max_support_levels: int = 64  # -: stack depth up to which support levels are computed
    warm_start: bool = True  # reuse last step's impulses of contacts matched by (sphere, sphere) key
    warm_start_factor: float = 1.0  # -: fraction of the previous impulse reused
    sleep_enabled: bool = True
    sleep_linear_speed_mps: float = 0.05  # m/s: below this (and the angular one) a body may sleep
    sleep_angular_speed_radps: float = 0.1  # rad/s
    time_to_sleep_s: float = 0.5  # s: an island sleeps after every body was slow this long

    _RANGES = {
        "substeps": (1, 64),
        "velocity_iterations": (1, 1000),
        "restitution_iterations": (0, 100),
        "position_iterations": (0, 1000),
        "restitution_threshold_mps": (0.0, 1e3),
        "linear_slop_m": (0.0, 1.0),
        "position_correction_rate": (0.0, 1.0),
        "max_correction_speed_mps": (0.0, 1e3),
        "speculative_margin_m": (0.0, 10.0),
        "linear_damping_per_s": (0.0, 1e6),
        "angular_damping_per_s": (0.0, 1e6),
        "max_speed_mps": (1e-6, 1e6),
        "max_rotation_per_step_rad": (1e-6, math.pi),
        "warm_start_factor": (0.0, 1.0),
        "max_support_levels": (0, 100000),
        "mass_ratio_cap": (0.0, 1e12),
        "sleep_linear_speed_mps": (0.0, 1e3),
        "sleep_angular_speed_radps": (0.0, 1e3),
        "time_to_sleep_s": (0.0, 1e6),
    }

    def validate(self) -> None:
        """Raise ConfigError naming the key, its value and the allowed range."""
        g = tuple(self.gravity)
        if len(g) != 3 or not all(math.isfinite(float(c)) for c in g):
            raise ConfigError("rigid.gravity", self.gravity, "three finite numbers (m/s^2)")
        for f in fields(self):
            if f.name in self._RANGES:
                lo, hi = self._RANGES[f.name]
                val = getattr(self, f.name)
                if not (isinstance(val, (int, float)) and math.isfinite(val) and lo <= val <= hi):
                    raise ConfigError(f"rigid.{f.name}", val, f"[{lo}, {hi}]")


@dataclass
class BodyState:
    """Pose and velocity of all bodies (index = body id), numpy copies."""

    x: np.ndarray  # (NB, 3) m: COM world position
    q: np.ndarray  # (NB, 4) -: w-x-y-z
    v: np.ndarray  # (NB, 3) m/s
    w: np.ndarray  # (NB, 3) rad/s, world frame
    asleep: np.ndarray  # (NB,) bool
    alive: np.ndarray  # (NB,) bool
    sleep_time: np.ndarray | None = None  # (NB,) s: time spent below the sleep speeds


@dataclass
class ContactEvents:
    """Contacts of the last step, one row per (sphere, sphere) or (sphere, collider) contact.

    body_b is -1 for a static collider (then `collider` names it; otherwise collider = -1). The
    normal points from B towards A; `normal_impulse` (N s) is the total impulse the step applied
    (velocity and restitution passes, not the position correction); `normal_speed` (m/s) is the
    relative normal velocity of A with respect to B before the solve (negative = closing).
    """

    body_a: np.ndarray  # (C,) int
    body_b: np.ndarray  # (C,) int
    sphere_a: np.ndarray  # (C,) int
    sphere_b: np.ndarray  # (C,) int: -1 for a collider
    collider: np.ndarray  # (C,) int: -1 for a sphere-sphere contact
    point: np.ndarray  # (C, 3) m
    normal: np.ndarray  # (C, 3) -
    normal_impulse: np.ndarray  # (C,) N s
    normal_speed: np.ndarray  # (C,) m/s
    separation: np.ndarray  # (C,) m: gap at the step start (negative = penetration)

    def __len__(self) -> int:
        return len(self.body_a)

    def touching(self) -> ContactEvents:
        """Only the contacts that carried impulse."""
        return self._select(self.normal_impulse > 0.0)

    def _select(self, mask: np.ndarray) -> ContactEvents:
        return ContactEvents(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})

    def by_body_pair(self) -> dict:
        """Impacts summed per body pair: arrays body_a, body_b, impulse (N s, summed), speed (m/s, most
        negative pre-solve normal speed), point (impulse-weighted mean), normal (impulse-weighted,
        normalised). Only contacts with impulse > 0 count."""
        ev = self.touching()
        if len(ev) == 0:
            z = np.zeros(0)
            return dict(
                body_a=z.astype(int),
                body_b=z.astype(int),
                impulse=z,
                speed=z,
                point=np.zeros((0, 3)),
                normal=np.zeros((0, 3)),
            )
        pairs = np.stack([ev.body_a, ev.body_b], 1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        inv = inv.ravel()
        m = len(uniq)
        imp = np.bincount(inv, weights=ev.normal_impulse, minlength=m)
        speed = np.full(m, np.inf)
        np.minimum.at(speed, inv, ev.normal_speed)
        pt = np.stack(
            [np.bincount(inv, weights=ev.normal_impulse * ev.point[:, k], minlength=m) for k in range(3)], 1
        )
        nr = np.stack(
            [np.bincount(inv, weights=ev.normal_impulse * ev.normal[:, k], minlength=m) for k in range(3)], 1
        )
        nr /= np.maximum(np.linalg.norm(nr, axis=1, keepdims=True), 1e-300)
        return dict(
            body_a=uniq[:, 0], body_b=uniq[:, 1], impulse=imp, speed=speed, point=pt / imp[:, None], normal=nr
        )


@dataclass
class _HostBodies:
    """Fixed body data mirrored on the host (index = body id)."""

    mass: list = field(default_factory=list)  # kg: sum of the tet masses (also for a static body)
    inertia: list = field(default_factory=list)  # (3, 3) kg m^2: body-frame inertia about the COM
    inv_mass: list = field(default_factory=list)  # 1/kg
    ref_com: list = field(default_factory=list)  # (3,) m
    inv_inertia: list = field(default_factory=list)  # (3, 3) 1/(kg m^2)
    principal_q: list = field(default_factory=list)  # (4,)
    inv_principal: list = field(default_factory=list)  # (3,) 1/(kg m^2)
    restitution: list = field(default_factory=list)
    friction: list = field(default_factory=list)
    static: list = field(default_factory=list)  # bool
    sphere_count: list = field(default_factory=list)  # int: spheres of the body when added


class RigidWorld:
    """Rigid bodies on boundary spheres with static colliders; see the module docstring.

    Capacities are initial sizes: adding beyond them grows the store between steps (new fields,
    copy, old tree released); the contact store grows inside `step` when the narrow phase needs it.
    `max_*` bounds (None = unbounded) make growth stop with a CapacityError instead.
    """

    def __init__(
        self,
        capacity_bodies: int = 64,
        capacity_spheres: int = 1024,
        capacity_colliders: int = 8,
        capacity_contacts: int | None = None,
        config: RigidConfig | None = None,
        max_spheres: int | None = None,
    ) -> None:
        self.config = config or RigidConfig()
        self.config.validate()
        for name, val in (
            ("capacity_bodies", capacity_bodies),
            ("capacity_spheres", capacity_spheres),
            ("capacity_colliders", capacity_colliders),
        ):
            if int(val) < 1:
                raise ConfigError(f"rigid.{name}", val, ">= 1")
        nct = capacity_contacts if capacity_contacts is not None else 4 * int(capacity_spheres)
        self.max_spheres = max_spheres
        self._s = acquire_store(int(capacity_bodies), int(capacity_spheres), int(capacity_colliders), int(nct))
        self.time = 0.0  # s: simulated time
        self.step_count = 0
        self.grow_count = 0  # how many times the store was rebuilt bigger
        self.profile: dict | None = None  # set to {} to accumulate seconds per stage (bench only)
        self._reset_host()

    # ------------------------------------------------------------------ bookkeeping
    def _reset_host(self) -> None:
        self._nb = 0
        self._ns = 0
        self._ncol = 0
        self._nc = 0  # contacts of the last step
        self._hb = _HostBodies()
        fdt = numpy_float()
        self._sph_local = np.zeros((0, 3), fdt)
        self._sph_radius = np.zeros(0, fdt)
        self._sph_body = np.zeros(0, np.int32)
        self._col = dict(kind=[], x=[], q=[], n=[], half=[], restitution=[], friction=[])
        self._s.pc_valid[None] = 0

    def clear(self) -> None:
        """Remove every body and collider; keeps the capacity (and the compiled kernels)."""
        self._reset_host()
        self.time = 0.0
        self.step_count = 0

    def release(self) -> None:
        """Give the Taichi store back for reuse (rigid.store); the world is unusable afterwards."""
        if self._s is not None:
            recycle_store(self._s)
            self._s = None

    @property
    def n_bodies(self) -> int:
        """Body slots used (removed bodies included: ids are stable)."""
        return self._nb

    @property
    def n_spheres(self) -> int:
        return self._ns

    @property
    def n_contacts(self) -> int:
        """Contacts of the last step."""
        return self._nc

    @property
    def capacity(self) -> dict:
        s = self._s
        return dict(
            bodies=s.cap_bodies, spheres=s.cap_spheres, colliders=s.cap_colliders, contacts=s.cap_contacts
        )

    def body_mass(self, body: int) -> float:
        """kg: the sum of the body's tet masses; also for a static body, which the solver treats as
        immovable (inverse mass 0). Infinite only for `static_mass_properties` placeholders."""
        return float(self._hb.mass[body])

    def body_ref_com(self, body: int) -> np.ndarray:
        return np.array(self._hb.ref_com[body], dtype=np.float64)

    def body_inertia(self, body: int) -> np.ndarray:
        """(3, 3) kg m^2: body-frame inertia about the COM (after the floor of rigid.mass)."""
        return np.array(self._hb.inertia[body], dtype=np.float64)

    def body_is_static(self, body: int) -> bool:
        return bool(self._hb.static[body])

    def body_spheres(self, body: int) -> np.ndarray:
        """Indices of the body's boundary spheres (they change when another body is removed)."""
        return np.flatnonzero(self._sph_body == body)

    def sphere_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(local (NS,3) m body frame, radius (NS,) m, body (NS,)) of all spheres."""
        return self._sph_local.copy(), self._sph_radius.copy(), self._sph_body.copy()

    # ------------------------------------------------------------------ capacity
    def _grow(self, bodies: int = 0, spheres: int = 0, colliders: int = 0, contacts: int = 0) -> None:
        """Rebuild the store with at least the given capacities (doubling), copying all data."""
        old = self._s
        nb = old.cap_bodies if bodies <= old.cap_bodies else max(bodies, 2 * old.cap_bodies)
        ns = old.cap_spheres if spheres <= old.cap_spheres else max(spheres, 2 * old.cap_spheres)
        if self.max_spheres is not None and ns > self.max_spheres:
            if spheres > self.max_spheres:
                raise CapacityError(
                    f"rigid world: {spheres} boundary spheres exceed max_spheres = {self.max_spheres}; "
                    "raise the scene option rigid.max_spheres or use a larger boundary group size"
                )
            ns = self.max_spheres
        ncol = old.cap_colliders if colliders <= old.cap_colliders else max(colliders, 2 * old.cap_colliders)
        nct = old.cap_contacts if contacts <= old.cap_contacts else max(contacts, 2 * old.cap_contacts)
        nct = max(nct, 4 * ns if ns > old.cap_spheres else nct)
        state = self._download_bodies(self._nb)
        prev = self._download_prev()
        self._s = acquire_store(nb, ns, ncol, nct)
        self._upload_bodies(0, self._nb, state)
        self._upload_spheres(0, self._ns)
        self._upload_colliders(0, self._ncol)
        self._upload_prev(*prev)
        recycle_store(old)
        self.grow_count += 1

    def _ensure(self, bodies: int, spheres: int, colliders: int) -> None:
        s = self._s
        if bodies > s.cap_bodies or spheres > s.cap_spheres or colliders > s.cap_colliders:
            self._grow(bodies=bodies, spheres=spheres, colliders=colliders)

    # ------------------------------------------------------------------ transfers
    def _download_bodies(self, n: int) -> BodyState:
        fdt = numpy_float()
        m = max(n, 1)
        x = np.zeros((m, 3), fdt)
        q = np.zeros((m, 4), fdt)
        v = np.zeros((m, 3), fdt)
        w = np.zeros((m, 3), fdt)
        asleep = np.zeros(m, np.int32)
        st = np.zeros(m, fdt)
        alive = np.zeros(m, np.int32)
        if n > 0:
            K.k_download_bodies(self._s, n, x, q, v, w, asleep, st, alive)
        st_ = BodyState(
            x=x[:n].astype(np.float64),
            q=q[:n].astype(np.float64),
            v=v[:n].astype(np.float64),
            w=w[:n].astype(np.float64),
            asleep=asleep[:n].astype(bool),
            alive=alive[:n].astype(bool),
            sleep_time=st[:n].astype(np.float64),
        )
        return st_

    def _upload_bodies(self, start: int, n: int, state: BodyState, offset: int = 0) -> None:
        """Write bodies [start, start + n) from the host mirror and `state` rows [offset, offset + n)."""
        if n == 0:
            return
        fdt = numpy_float()
        hb = self._hb
        sl = slice(start, start + n)
        ss = slice(offset, offset + n)

        def arr(lst, dt=fdt):
            return np.ascontiguousarray(np.asarray(lst[sl], dtype=np.float64).astype(dt))

        sleep_time = state.sleep_time if state.sleep_time is not None else np.zeros(len(state.x))
        K.k_upload_bodies(
            self._s,
            start,
            n,
            arr(hb.inv_mass),
            arr(hb.ref_com),
            arr(hb.inv_inertia),
            arr(hb.principal_q),
            arr(hb.inv_principal),
            arr(hb.restitution),
            arr(hb.friction),
            arr(hb.static, np.int32),
            np.ascontiguousarray(state.alive[ss].astype(np.int32)),
            np.ascontiguousarray(state.x[ss].astype(fdt)),
            np.ascontiguousarray(state.q[ss].astype(fdt)),
            np.ascontiguousarray(state.v[ss].astype(fdt)),
            np.ascontiguousarray(state.w[ss].astype(fdt)),
            np.ascontiguousarray(state.asleep[ss].astype(np.int32)),
            np.ascontiguousarray(np.asarray(sleep_time[ss]).astype(fdt)),
        )

    def _upload_spheres(self, start: int, n: int) -> None:
        if n == 0:
            return
        fdt = numpy_float()
        sl = slice(start, start + n)
        K.k_upload_spheres(
            self._s,
            start,
            n,
            np.ascontiguousarray(self._sph_local[sl].astype(fdt)),
            np.ascontiguousarray(self._sph_radius[sl].astype(fdt)),
            np.ascontiguousarray(self._sph_body[sl]),
        )

    def _upload_colliders(self, start: int, n: int) -> None:
        if n == 0:
            return
        fdt = numpy_float()
        c = self._col
        sl = slice(start, start + n)

        def arr(key, dt=fdt):
            return np.ascontiguousarray(np.asarray(c[key][sl], dtype=np.float64).astype(dt))

        K.k_upload_colliders(
            self._s,
            start,
            n,
            arr("kind", np.int32),
            arr("x"),
            arr("q"),
            arr("n"),
            arr("half"),
            arr("restitution"),
            arr("friction"),
        )

    def _download_prev(self):
        """(pc_b, pc_ln, pc_lt, pc_start, valid) of the previous step's contacts."""
        fdt = numpy_float()
        nc, ns = self._nc, self._ns
        pb = np.zeros(max(nc, 1), np.int32)
        pln = np.zeros(max(nc, 1), fdt)
        plt = np.zeros((max(nc, 1), 3), fdt)
        pstart = np.zeros(ns + 1, np.int32)
        valid = int(self._s.pc_valid[None])
        if valid:
            K.k_download_prev(self._s, nc, ns, pb, pln, plt, pstart)
        return pb[:nc], pln[:nc], plt[:nc], pstart, valid

    def _upload_prev(self, pb, pln, plt, pstart, valid) -> None:
        fdt = numpy_float()
        nc = len(pb)
        ns = len(pstart) - 1
        if nc > self._s.cap_contacts:  # only when shrinking, which never happens
            valid = 0
            nc = 0
        K.k_upload_prev(
            self._s,
            nc,
            ns,
            np.ascontiguousarray(np.r_[pb, 0].astype(np.int32)),
            np.ascontiguousarray(np.r_[pln, 0].astype(fdt)),
            np.ascontiguousarray(np.concatenate([plt, np.zeros((1, 3))]).astype(fdt)),
            np.ascontiguousarray(pstart.astype(np.int32)),
            int(valid),
        )
        self._nc = nc

    def _remap_prev(self, prev, old_to_new: np.ndarray, new_ns: int) -> None:
        """Renumber the warm-start contacts `prev` (from `_download_prev` before the change) after
        spheres were added or removed (old_to_new[i] = -1 for a removed sphere)."""
        pb, pln, plt, pstart, valid = prev
        if not valid or len(pb) == 0:
            self._upload_prev(pb[:0], pln[:0], plt[:0], np.zeros(new_ns + 1, np.int32), 0)
            return
        counts = np.diff(pstart)
        a_old = np.repeat(np.arange(len(counts)), counts)
        a_new = old_to_new[a_old]
        b_new = np.where(pb >= 0, old_to_new[np.maximum(pb, 0)], pb)
        keep = (a_new >= 0) & ((pb < 0) | (b_new >= 0))
        a_new, b_new, pln, plt = a_new[keep], b_new[keep], pln[keep], plt[keep]
        order = np.lexsort((b_new, a_new))
        a_new, b_new, pln, plt = a_new[order], b_new[order], pln[order], plt[order]
        start = np.zeros(new_ns + 1, np.int64)
        np.cumsum(np.bincount(a_new, minlength=new_ns), out=start[1:])
        self._upload_prev(b_new, pln, plt, start, 1)

    # ------------------------------------------------------------------ building
    def add_plane(self, point, normal, restitution: float = 0.0, friction: float = 0.5) -> int:
        """Static half-space {x : (x - point) . n <= 0} (solid below); returns the collider id."""
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise ConfigError("collider.normal", normal, "a finite non-zero 3-vector")
        return self._add_collider(
            0, point, IDENTITY, n / np.linalg.norm(n), np.zeros(3), restitution, friction
        )

    def add_box_collider(
        self, center, half_extents, q=IDENTITY, restitution: float = 0.0, friction: float = 0.5
    ) -> int:
        """Static oriented box (centre m, half extents m, w-x-y-z orientation); returns the collider id."""
        h = np.asarray(half_extents, dtype=np.float64)
        if h.shape != (3,) or not np.all(h > 0):
            raise ConfigError("collider.half_extents", half_extents, "three positive lengths (m)")
        q = np.asarray(q, dtype=np.float64)
        return self._add_collider(
            1, center, q / np.linalg.norm(q), np.array([0.0, 1.0, 0.0]), h, restitution, friction
        )

    def _add_collider(self, kind, x, q, n, half, restitution, friction) -> int:
        _check_material("collider", restitution, friction)
        x = np.asarray(x, dtype=np.float64)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise ConfigError("collider.position", x, "a finite 3-vector (m)")
        self._ensure(self._nb, self._ns, self._ncol + 1)
        c = self._col
        for key, val in (
            ("kind", kind),
            ("x", x),
            ("q", q),
            ("n", n),
            ("half", half),
            ("restitution", restitution),
            ("friction", friction),
        ):
            c[key].append(val)
        self._upload_colliders(self._ncol, 1)
        self._ncol += 1
        return self._ncol - 1

    def add_body(
        self,
        mass: MassProperties,
        sphere_local: np.ndarray,
        sphere_radius: np.ndarray,
        x=None,
        q=IDENTITY,
        v=(0.0, 0.0, 0.0),
        w=(0.0, 0.0, 0.0),
        static: bool = False,
        restitution: float = 0.0,
        friction: float = 0.5,
    ) -> int:
        """Add one body; returns its id. See `add_bodies`."""
        return self.add_bodies(
            [
                dict(
                    mass=mass,
                    sphere_local=sphere_local,
                    sphere_radius=sphere_radius,
                    x=x,
                    q=q,
                    v=v,
                    w=w,
                    static=static,
                    restitution=restitution,
                    friction=friction,
                )
            ]
        )[0]

    def add_bodies(self, specs: list[dict]) -> list[int]:
        """Add bodies between steps; returns their ids (consecutive).

        Each spec: mass (MassProperties, reference frame), sphere_local ((B,3) m, X_ref - ref_com),
        sphere_radius ((B,) m), x (COM world position; default mass.com, i.e. the rest pose),
        q (w-x-y-z, default identity), v (m/s), w (rad/s, world), static, restitution, friction.
        """
        if not specs:
            return []
        fdt = numpy_float()
        rows = []
        new_local, new_rad, new_body = [], [], []
        for u, sp in enumerate(specs):
            bid = self._nb + u
            mp: MassProperties = sp["mass"]
            static = bool(sp.get("static", False))
            rest = float(sp.get("restitution", 0.0))
            fric = float(sp.get("friction", 0.5))
            _check_material(f"body {bid}", rest, fric)
            loc = np.asarray(sp["sphere_local"], dtype=np.float64).reshape(-1, 3)
            rad = np.asarray(sp["sphere_radius"], dtype=np.float64).reshape(-1)
            if len(loc) == 0 or len(loc) != len(rad):
                raise ConfigError(
                    f"body {bid}.spheres", (len(loc), len(rad)), "at least one sphere, one radius each"
                )
            if not (np.all(np.isfinite(loc)) and np.all(np.isfinite(rad)) and np.all(rad > 0)):
                raise ConfigError(f"body {bid}.sphere_radius", rad.min(initial=0.0), "finite, > 0 m")
            if not static and not (math.isfinite(mp.mass) and mp.mass > 0):
                raise ConfigError(f"body {bid}.mass", mp.mass, "finite, > 0 kg for a dynamic body")
            x = np.asarray(mp.com if sp.get("x") is None else sp["x"], dtype=np.float64)
            q = np.asarray(sp.get("q", IDENTITY), dtype=np.float64)
            q = q / np.linalg.norm(q)
            v = np.zeros(3) if static else np.asarray(sp.get("v", (0, 0, 0)), dtype=np.float64)
            w = np.zeros(3) if static else np.asarray(sp.get("w", (0, 0, 0)), dtype=np.float64)
            for name, val in (("x", x), ("v", v), ("w", w)):
                if val.shape != (3,) or not np.all(np.isfinite(val)):
                    raise ConfigError(f"body {bid}.{name}", val, "a finite 3-vector")
            rows.append((mp, static, rest, fric, x, q, v, w, len(loc)))
            new_local.append(loc)
            new_rad.append(rad)
            new_body.append(np.full(len(loc), bid, np.int32))
        nb_new = self._nb + len(specs)
        ns_add = sum(len(a) for a in new_local)
        self._ensure(nb_new, self._ns + ns_add, self._ncol)
        hb = self._hb
        for mp, static, rest, fric, *_rest, nsph in rows:
            hb.mass.append(float(mp.mass))
            hb.inertia.append(np.asarray(mp.inertia, dtype=np.float64))
            if static:
                hb.inv_mass.append(0.0)
                hb.inv_inertia.append(np.zeros((3, 3)))
                hb.inv_principal.append(np.zeros(3))
                hb.principal_q.append(IDENTITY.copy())
            else:
                hb.inv_mass.append(1.0 / mp.mass)
                hb.inv_inertia.append(mp.inv_inertia)
                hb.inv_principal.append(1.0 / mp.principal_moments)
                hb.principal_q.append(mp.principal_q)
            hb.ref_com.append(np.asarray(mp.com, dtype=np.float64))
            hb.restitution.append(rest)
            hb.friction.append(fric)
            hb.static.append(static)
            hb.sphere_count.append(nsph)
        state = BodyState(
            x=np.array([r[4] for r in rows]),
            q=np.array([r[5] for r in rows]),
            v=np.array([r[6] for r in rows]),
            w=np.array([r[7] for r in rows]),
            asleep=np.zeros(len(rows), bool),
            alive=np.ones(len(rows), bool),
        )
        self._upload_bodies(self._nb, len(rows), state)
        prev = self._download_prev()
        old_ns = self._ns
        self._sph_local = np.concatenate([self._sph_local, np.concatenate(new_local).astype(fdt)])
        self._sph_radius = np.concatenate([self._sph_radius, np.concatenate(new_rad).astype(fdt)])
        self._sph_body = np.concatenate([self._sph_body, np.concatenate(new_body)])
        self._ns = len(self._sph_radius)
        self._upload_spheres(old_ns, self._ns - old_ns)
        self._remap_prev(prev, np.arange(old_ns), self._ns)
        ids = list(range(self._nb, nb_new))
        self._nb = nb_new
        return ids

    def remove_bodies(self, ids) -> None:
        """Remove bodies between steps (their ids stay reserved); wakes sleeping bodies near them."""
        ids = np.unique(np.asarray(ids, dtype=np.int64).reshape(-1))
        if len(ids) == 0:
            return
        if ids.min() < 0 or ids.max() >= self._nb:
            raise ConfigError("remove_bodies.ids", ids.tolist(), f"body ids in [0, {self._nb})")
        st = self._download_bodies(self._nb)
        self.wake_near(ids, state=st)
        zero3 = np.zeros(3)
        for b in ids:
            K.k_set_body_state(
                self._s,
                int(b),
                st.x[b].astype(numpy_float()),
                st.q[b].astype(numpy_float()),
                zero3.astype(numpy_float()),
                zero3.astype(numpy_float()),
                0,
                0,
            )
        prev = self._download_prev()
        keep = ~np.isin(self._sph_body, ids)
        old_to_new = np.full(self._ns, -1, np.int64)
        old_to_new[keep] = np.arange(int(keep.sum()))
        self._sph_local = self._sph_local[keep]
        self._sph_radius = self._sph_radius[keep]
        self._sph_body = self._sph_body[keep]
        self._ns = len(self._sph_radius)
        self._upload_spheres(0, self._ns)
        self._remap_prev(prev, old_to_new, self._ns)

    def wake_near(self, ids, state: BodyState | None = None, pad: float | None = None) -> np.ndarray:
        """Wake every body with a sphere within `pad` (default: the largest sphere diameter plus the
        speculative margin) of the spheres of bodies `ids`; returns the ids woken."""
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        st = state or self._download_bodies(self._nb)
        if self._ns == 0:
            return np.zeros(0, np.int64)
        xw = self.sphere_world(st)
        mine = np.isin(self._sph_body, ids)
        if not mine.any():
            return np.zeros(0, np.int64)
        if pad is None:
            pad = 2.0 * float(self._sph_radius.max()) + self.config.speculative_margin_m
        lo = (xw[mine] - self._sph_radius[mine, None]).min(0) - pad
        hi = (xw[mine] + self._sph_radius[mine, None]).max(0) + pad
        near = np.all((xw >= lo) & (xw <= hi), axis=1) & ~mine
        woken = np.unique(self._sph_body[near]).astype(np.int64)
        self.wake(woken)
        return woken

    def wake(self, ids) -> None:
        """Wake bodies (no effect on static, removed or awake ones)."""
        ids = np.ascontiguousarray(np.asarray(ids, dtype=np.int32).reshape(-1))
        if len(ids):
            K.k_wake(self._s, ids, len(ids))

    def set_body_state(self, body: int, x=None, q=None, v=None, w=None) -> None:
        """Overwrite the pose/velocity of a body between steps (wakes it)."""
        st = self._download_bodies(self._nb)
        fdt = numpy_float()
        x = st.x[body] if x is None else np.asarray(x, dtype=np.float64)
        q = st.q[body] if q is None else np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
        v = st.v[body] if v is None else np.asarray(v, dtype=np.float64)
        w = st.w[body] if w is None else np.asarray(w, dtype=np.float64)
        K.k_set_body_state(
            self._s,
            int(body),
            x.astype(fdt),
            q.astype(fdt),
            v.astype(fdt),
            w.astype(fdt),
            0,
            int(st.alive[body]),
        )

    # ------------------------------------------------------------------ reading
    def awake_bodies(self) -> int:
        """Dynamic bodies not asleep (one kernel; no download of the body state)."""
        return int(K.k_count_awake(self._s, self._nb)) if self._nb else 0

    def body_state(self) -> BodyState:
        """Numpy copy of every body's pose and velocity (index = body id)."""
        return self._download_bodies(self._nb)

    def sphere_world(self, state: BodyState | None = None) -> np.ndarray:
        """(NS, 3) m: world centres of the boundary spheres at the current poses."""
        st = state or self._download_bodies(self._nb)
        if self._ns == 0:
            return np.zeros((0, 3))
        b = self._sph_body
        rot = quat_to_matrix(st.q[b])
        return np.einsum("nij,nj->ni", rot, self._sph_local.astype(np.float64)) + st.x[b]

    def contact_events(self) -> ContactEvents:
        """Contacts of the last step (see ContactEvents)."""
        fdt = numpy_float()
        nc = self._nc
        m = max(nc, 1)
        a = np.zeros(m, np.int32)
        b = np.zeros(m, np.int32)
        ba = np.zeros(m, np.int32)
        bb = np.zeros(m, np.int32)
        p = np.zeros((m, 3), fdt)
        n = np.zeros((m, 3), fdt)
        ln = np.zeros(m, fdt)
        vn0 = np.zeros(m, fdt)
        sep = np.zeros(m, fdt)
        if nc > 0:
            K.k_download_contacts(self._s, nc, a, b, ba, bb, p, n, ln, vn0, sep)
        a, b, ba, bb = a[:nc], b[:nc], ba[:nc], bb[:nc]
        return ContactEvents(
            body_a=ba.astype(np.int64),
            body_b=bb.astype(np.int64),
            sphere_a=a.astype(np.int64),
            sphere_b=np.where(b >= 0, b, -1).astype(np.int64),
            collider=np.where(b < 0, -1 - b, -1).astype(np.int64),
            point=p[:nc].astype(np.float64),
            normal=n[:nc].astype(np.float64),
            normal_impulse=ln[:nc].astype(np.float64),
            normal_speed=vn0[:nc].astype(np.float64),
            separation=sep[:nc].astype(np.float64),
        )

    def kinetic_energy(self, state: BodyState | None = None) -> float:
        """J: total kinetic energy of the dynamic bodies."""
        st = state or self._download_bodies(self._nb)
        e = 0.0
        for b in range(self._nb):
            if not st.alive[b] or self._hb.static[b]:
                continue
            rot = quat_to_matrix(st.q[b])
            inertia = rot @ self.body_inertia(b) @ rot.T
            e += 0.5 * self._hb.mass[b] * st.v[b] @ st.v[b] + 0.5 * st.w[b] @ inertia @ st.w[b]
        return e

    # ------------------------------------------------------------------ stepping
    def _lap_start(self):
        """Stage timer (Box2D-style profile): with `self.profile` a dict, adds seconds per stage to it
        (synchronising the device between stages, which costs a little); otherwise does nothing."""
        if self.profile is None:
            return lambda _name: None
        import time

        import taichi as ti

        ti.sync()
        t = [time.perf_counter()]

        def lap(name: str) -> None:
            ti.sync()
            now = time.perf_counter()
            self.profile[name] = self.profile.get(name, 0.0) + now - t[0]
            t[0] = now

        return lap

    def step(self, dt: float) -> None:
        """Advance by dt seconds (stages in rigid.kernels)."""
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0.0 < dt <= 0.1):
            raise ConfigError("rigid.dt", dt, "(0, 0.1] s")
        cfg = self.config
        nb, ns, ncol = self._nb, self._ns, self._ncol
        if nb == 0:
            self.time += dt
            self.step_count += 1
            return
        g = cfg.gravity
        margin = cfg.speculative_margin_m
        lap = self._lap_start()
        while True:
            s = self._s
            K.k_derive(s, nb, ns, dt)
            K.k_grid(s, ns, margin)
            lap("broad_phase")
            K.k_count(s, nb, ns, ncol, margin)
            total = int(s.ct_total[None])
            if total <= s.cap_contacts:
                break
            self._grow(contacts=total)
        s = self._s
        nc = total
        K.k_gather(s, ns, ncol, margin)
        K.k_setup(s, nc, int(cfg.warm_start), cfg.warm_start_factor)
        h = dt / cfg.substeps
        if cfg.mass_ratio_cap > 0.0:
            K.k_levels(s, nb, nc, cfg.max_support_levels)
            K.k_mass_scaling(s, nc, cfg.mass_ratio_cap)
        lap("narrow_phase")
        for sub in range(cfg.substeps):
            K.k_substep(
                s,
                nb,
                nc,
                h,
                float(g[0]),
                float(g[1]),
                float(g[2]),
                cfg.linear_damping_per_s,
                cfg.angular_damping_per_s,
                cfg.max_speed_mps,
                cfg.max_rotation_per_step_rad / cfg.substeps,
                cfg.velocity_iterations,
                sub % 2,
            )
        lap("solve_integrate")
        K.k_correct(
            s,
            nb,
            nc,
            dt,
            cfg.position_iterations,
            cfg.linear_slop_m,
            cfg.position_correction_rate,
            cfg.max_correction_speed_mps,
        )
        K.k_finish(
            s,
            nb,
            nc,
            cfg.restitution_iterations,
            cfg.restitution_threshold_mps,
            cfg.sleep_linear_speed_mps,
            cfg.sleep_angular_speed_radps,
            dt,
        )
        lap("correct_restitute")
        K.k_save_prev(s, nc, ns)
        self._nc = nc
        if cfg.sleep_enabled:
            K.k_sleep(s, nb, nc, cfg.time_to_sleep_s)
        lap("sleep")
        self.time += dt
        self.step_count += 1


def _check_material(where: str, restitution: float, friction: float) -> None:
    if not (math.isfinite(restitution) and 0.0 <= restitution <= 1.0):
        raise ConfigError(f"{where}.restitution", restitution, "[0, 1]")
    if not (math.isfinite(friction) and 0.0 <= friction <= 10.0):
        raise ConfigError(f"{where}.friction", friction, "[0, 10]")
