"""The rigid world: bodies made of boundary spheres, static colliders, and the impulse-based step.

A lightweight impulse-based integrator in Taichi, standing in for the commercial engine of the
paper (Sect. 6.1 used Newton Game Dynamics); collision runs on boundary particles only (Sect. 5.3).
The stages and their equations are described in rigid/step.py; conventions, parameters and the
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
from dataclasses import dataclass, field

import numpy as np

from core.errors import CapacityError, ConfigError
from core.runtime import numpy_float
from rigid.free_flight import FreeFlight
from rigid.host_sync import HostSync
from rigid.mass import MassProperties
from rigid.quat import IDENTITY, quat_to_matrix
from rigid.records import BodyState, ContactEvents, RigidConfig
from rigid.step import rigid_step
from rigid.store import acquire_store, recycle_store


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

    def append(self, mp, static: bool, restitution: float, friction: float, spheres: int) -> None:
        """One body's fixed data (a static body has zero inverse mass and inertia)."""
        self.mass.append(float(mp.mass))
        self.inertia.append(np.asarray(mp.inertia, dtype=np.float64))
        if static:
            self.inv_mass.append(0.0)
            self.inv_inertia.append(np.zeros((3, 3)))
            self.inv_principal.append(np.zeros(3))
            self.principal_q.append(IDENTITY.copy())
        else:
            self.inv_mass.append(1.0 / mp.mass)
            self.inv_inertia.append(mp.inv_inertia)
            self.inv_principal.append(1.0 / mp.principal_moments)
            self.principal_q.append(mp.principal_q)
        self.ref_com.append(np.asarray(mp.com, dtype=np.float64))
        self.restitution.append(restitution)
        self.friction.append(friction)
        self.static.append(static)
        self.sphere_count.append(spheres)


class RigidWorld(HostSync):
    """Rigid bodies on boundary spheres with static colliders; see the module docstring.

    Capacities are initial sizes: adding beyond them grows the store between steps (new fields, copy,
    old tree released; the step's kernels compile again, ~2 s), the contacts inside `step`. `max_*`
    bounds (None = unbounded) stop growth with a CapacityError; `on_grow(kind, needed, capacity)` is
    told before each growth (the World names the scene option that avoids it).
    """

    def __init__(
        self,
        capacity_bodies: int = 64,
        capacity_spheres: int = 1024,
        capacity_colliders: int = 8,
        capacity_contacts: int | None = None,
        config: RigidConfig | None = None,
        max_spheres: int | None = None,
        on_grow=None,
    ) -> None:
        self.config = config or RigidConfig()
        self.on_grow = on_grow
        self.config.validate()
        caps = dict(capacity_bodies=capacity_bodies, capacity_spheres=capacity_spheres,
                    capacity_colliders=capacity_colliders)
        for name, val in caps.items():
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
        self._nb = self._ns = self._ncol = 0  # bodies, spheres, colliders
        self._nc = 0  # contacts of the last step
        self._hb = _HostBodies()
        fdt = numpy_float()
        self._sph_local = np.zeros((0, 3), fdt)
        self._sph_radius = np.zeros(0, fdt)
        self._sph_body = np.zeros(0, np.int32)
        self._col = dict(kind=[], x=[], q=[], n=[], half=[], restitution=[], friction=[])
        self.write_scalar("pc_valid", 0)
        self.free_flight = FreeFlight(self)  # which frames before the first contact step the bodies alone

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
        return {k: getattr(self._s, f"cap_{k}") for k in ("bodies", "spheres", "colliders", "contacts")}

    def body_mass(self, body: int) -> float:
        """kg: the sum of the body's tet masses; also for a static body, which the solver treats as
        immovable (inverse mass 0). Infinite only for `static_mass_properties` placeholders."""
        return float(self._hb.mass[body])

    def body_ref_com(self, body: int) -> np.ndarray:
        return np.array(self._hb.ref_com[body], dtype=np.float64)

    def ref_coms(self) -> np.ndarray:
        """(NB, 3) m: every body's centre of mass in its reference frame (body_x is where it is now)."""
        return np.array(self._hb.ref_com[: self._nb], dtype=np.float64).reshape(-1, 3)

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
        for kind, needed, cap in (("bodies", bodies, old.cap_bodies), ("spheres", spheres, old.cap_spheres),
                                  ("contacts", contacts, old.cap_contacts)):
            if needed > cap and self.on_grow is not None:
                self.on_grow(kind, needed, cap)
        nb = old.cap_bodies if bodies <= old.cap_bodies else max(bodies, 2 * old.cap_bodies)
        ns = old.cap_spheres if spheres <= old.cap_spheres else max(spheres, 2 * old.cap_spheres)
        if self.max_spheres is not None and ns > self.max_spheres:
            if spheres > self.max_spheres:
                raise CapacityError(
                    f"rigid world: {spheres} boundary spheres exceed max_spheres = {self.max_spheres}; "
                    "raise max_spheres or use a larger boundary group size"
                )
            ns = self.max_spheres
        ncol = old.cap_colliders if colliders <= old.cap_colliders else max(colliders, 2 * old.cap_colliders)
        nct = old.cap_contacts if contacts <= old.cap_contacts else max(contacts, 2 * old.cap_contacts)
        nct = max(nct, 4 * ns if ns > old.cap_spheres else nct)
        state = self._state()
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

    def add_plane(self, point, normal, restitution: float = 0.0, friction: float = 0.5) -> int:
        """Static half-space {x : (x - point) . n <= 0} (solid below); returns the collider id."""
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise ConfigError("collider.normal", normal, "a finite non-zero 3-vector")
        return self._add_collider(0, point, IDENTITY, n / np.linalg.norm(n), np.zeros(3), restitution, friction)

    def add_box_collider(
        self, center, half_extents, q=IDENTITY, restitution: float = 0.0, friction: float = 0.5
    ) -> int:
        """Static oriented box (centre m, half extents m, w-x-y-z orientation); returns the collider id."""
        h = np.asarray(half_extents, dtype=np.float64)
        if h.shape != (3,) or not np.all(h > 0):
            raise ConfigError("collider.half_extents", half_extents, "three positive lengths (m)")
        q = np.asarray(q, dtype=np.float64)
        return self._add_collider(1, center, q / np.linalg.norm(q), np.array([0.0, 1.0, 0.0]), h, restitution,
                                  friction)

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
        return self.replace_bodies((), specs)

    def remove_bodies(self, ids) -> None:
        """Remove bodies between steps (their ids stay reserved); wakes sleeping bodies near them."""
        self.replace_bodies(ids, [])

    def replace_bodies(self, ids, specs: list[dict]) -> list[int]:
        """`remove_bodies(ids)` then `add_bodies(specs)` as one change (split_body: a parent by its
        pieces): the spheres after the first removed one are uploaded, and the warm-start contacts
        renumbered, once. Returns the new bodies' ids."""
        ids = np.unique(np.asarray(ids, dtype=np.int64).reshape(-1))
        if len(ids) and (ids.min() < 0 or ids.max() >= self._nb):
            raise ConfigError("remove_bodies.ids", ids.tolist(), f"body ids in [0, {self._nb})")
        if len(ids) == 0 and not specs:
            return []
        fdt = numpy_float()
        if len(ids):
            st = self._state()
            self.wake_near(ids, state=st)
            zero3 = np.zeros(3, fdt)
            for b in ids:  # at rest where it was, not alive
                self._write_body_state(int(b), st.x[b].astype(fdt), st.q[b].astype(fdt), zero3, zero3, 0, 0)
        rows, new_local, new_rad, new_body = [], [], [], []
        for u, sp in enumerate(specs):
            row, loc, rad = _checked_spec(self._nb + u, sp)
            rows.append(row)
            new_local.append(loc.astype(fdt))
            new_rad.append(rad.astype(fdt))
            new_body.append(np.full(len(loc), self._nb + u, np.int32))
        keep = ~np.isin(self._sph_body, ids)
        n_kept = int(keep.sum())
        self._ensure(self._nb + len(specs), n_kept + sum(len(a) for a in new_local), self._ncol)
        for mp, static, rest, fric, *_rest, nsph in rows:
            self._hb.append(mp, static, rest, fric, nsph)
        if specs:
            state = BodyState(x=np.array([r[4] for r in rows]), q=np.array([r[5] for r in rows]),
                              v=np.array([r[6] for r in rows]), w=np.array([r[7] for r in rows]),
                              asleep=np.zeros(len(rows), bool), alive=np.ones(len(rows), bool))
            self._upload_bodies(self._nb, len(rows), state)
        prev = self._download_prev()
        old_to_new = np.full(self._ns, -1, np.int64)
        old_to_new[keep] = np.arange(n_kept)
        first = int(np.argmin(keep)) if n_kept < self._ns else self._ns  # the first sphere that moves
        self._sph_local = np.concatenate([self._sph_local[keep], *new_local])
        self._sph_radius = np.concatenate([self._sph_radius[keep], *new_rad])
        self._sph_body = np.concatenate([self._sph_body[keep], *new_body])
        self._ns = len(self._sph_radius)
        self._upload_spheres(first, self._ns - first)
        self._remap_prev(prev, old_to_new, self._ns)
        new_ids = list(range(self._nb, self._nb + len(specs)))
        self._nb += len(specs)
        return new_ids

    def wake_near(self, ids, state: BodyState | None = None, pad: float | None = None) -> np.ndarray:
        """Wake every body with a sphere within `pad` (default: the largest sphere diameter plus the
        speculative margin) of the spheres of bodies `ids`; returns the ids woken."""
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        st = state or self._state()
        if self._ns == 0:
            return np.zeros(0, np.int64)
        mine = np.isin(self._sph_body, ids)
        if not mine.any():
            return np.zeros(0, np.int64)
        if pad is None:
            pad = 2.0 * float(self._sph_radius.max()) + self.config.speculative_margin_m
        xm = self.sphere_world(st, np.flatnonzero(mine))
        lo = (xm - self._sph_radius[mine, None]).min(0) - pad
        hi = (xm + self._sph_radius[mine, None]).max(0) + pad
        # a sphere centre in the box needs its body's bounding sphere to reach it: the others' are not placed
        gap = np.linalg.norm(np.maximum(np.maximum(lo - st.x[: self._nb], st.x[: self._nb] - hi), 0.0), axis=1)
        candidate = np.flatnonzero((gap <= self.body_reach() * (1.0 + 1e-6) + 1e-9)[self._sph_body] & ~mine)
        xw = self.sphere_world(st, candidate)
        near = np.all((xw >= lo) & (xw <= hi), axis=1)
        woken = np.unique(self._sph_body[candidate[near]]).astype(np.int64)
        self.wake(woken)
        return woken

    def wake(self, ids) -> None:
        """Wake bodies (no effect on static, removed or awake ones)."""
        ids = np.ascontiguousarray(np.asarray(ids, dtype=np.int32).reshape(-1))
        if len(ids):
            self._wake_bodies(ids)

    def set_body_state(self, body: int, x=None, q=None, v=None, w=None) -> None:
        """Overwrite the pose/velocity of a body between steps (wakes it)."""
        st = self._state()
        fdt = numpy_float()
        x = st.x[body] if x is None else np.asarray(x, dtype=np.float64)
        q = st.q[body] if q is None else np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
        v = st.v[body] if v is None else np.asarray(v, dtype=np.float64)
        w = st.w[body] if w is None else np.asarray(w, dtype=np.float64)
        self._write_body_state(int(body), x.astype(fdt), q.astype(fdt), v.astype(fdt), w.astype(fdt), 0,
                               int(st.alive[body]))

    # ------------------------------------------------------------------ reading
    def awake_bodies(self) -> int:
        """Dynamic bodies alive and awake, counted on the downloaded body state (no kernel of its own)."""
        st = self._state()
        return int(np.count_nonzero(st.alive & ~st.asleep & ~self.static_mask()))

    def body_state(self, fresh: bool = False) -> BodyState:
        """Numpy copy of every body's pose and velocity (index = body id). `fresh`: downloaded now, not
        the copy kept since the last write (the guards look for values written to the store directly)."""
        return self._download_bodies(self._nb) if fresh else self._state().copy()

    def sphere_world(self, state: BodyState | None = None, spheres=None) -> np.ndarray:
        """(NS, 3) m: world centres of the boundary spheres (or of the indices `spheres`) at the current poses."""
        st = state or self._state()
        sel = slice(None) if spheres is None else np.asarray(spheres, dtype=np.int64)
        b = self._sph_body[sel]
        rot = quat_to_matrix(st.q[: self._nb])[b]  # one matrix per body, gathered (Pots: 150 bodies, 50k spheres)
        return np.einsum("nij,nj->ni", rot, self._sph_local[sel].astype(np.float64)) + st.x[b]

    def fastest_closing(self) -> float:
        """m/s: the fastest pre-solve closing speed among the last step's contacts that carried impulse (0
        if none): an impact above a threshold needs one above it, so a step without one downloads nothing."""
        return float(self.read_scalar("max_closing"))

    def contact_events(self) -> ContactEvents:
        """Contacts of the last step (see ContactEvents)."""
        a, b, ba, bb, p, n, ln, vn0, sep = self._download_contacts()
        rad = self._sph_radius.astype(np.float64)
        return ContactEvents(
            body_a=ba.astype(np.int64),
            body_b=bb.astype(np.int64),
            sphere_a=a.astype(np.int64),
            sphere_b=np.where(b >= 0, b, -1).astype(np.int64),
            collider=np.where(b < 0, -1 - b, -1).astype(np.int64),
            point=p.astype(np.float64),
            normal=n.astype(np.float64),
            normal_impulse=ln.astype(np.float64),
            normal_speed=vn0.astype(np.float64),
            separation=sep.astype(np.float64),
            site_radius=np.maximum(rad[a], np.where(b >= 0, rad[np.maximum(b, 0)], 0.0)),
        )

    def kinetic_energy(self, state: BodyState | None = None) -> float:
        """J: total kinetic energy of the dynamic bodies."""
        st = state or self._state()
        e = 0.0
        for b in range(self._nb):
            if not st.alive[b] or self._hb.static[b]:
                continue
            rot = quat_to_matrix(st.q[b])
            inertia = rot @ self.body_inertia(b) @ rot.T
            e += 0.5 * self._hb.mass[b] * st.v[b] @ st.v[b] + 0.5 * st.w[b] @ inertia @ st.w[b]
        return e

    # ------------------------------------------------------------------ stepping
    def step(self, dt: float, split: bool = True, free: bool = False) -> None:
        """Advance by dt seconds: the stages of rigid/step.py, in `travel_splits` parts (split=False: the
        caller split the step already, as the World does to read impacts from every part; free=True: the
        caller knows no contact can be made, rigid/free_flight.py)."""
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0.0 < dt <= 0.1):
            raise ConfigError("rigid.dt", dt, "(0, 0.1] s")
        rigid_step(self, dt, split, free)


def _checked_spec(bid: int, sp: dict):
    """One body spec of RigidWorld.add_bodies, checked: ((mass, static, restitution, friction, x, q,
    v, w, sphere count), sphere centres (B, 3) m, radii (B,) m); ConfigError naming the body."""
    mp: MassProperties = sp["mass"]
    static = bool(sp.get("static", False))
    rest = float(sp.get("restitution", 0.0))
    fric = float(sp.get("friction", 0.5))
    _check_material(f"body {bid}", rest, fric)
    loc = np.asarray(sp["sphere_local"], dtype=np.float64).reshape(-1, 3)
    rad = np.asarray(sp["sphere_radius"], dtype=np.float64).reshape(-1)
    if len(loc) == 0 or len(loc) != len(rad):
        raise ConfigError(f"body {bid}.spheres", (len(loc), len(rad)), "at least one sphere, one radius each")
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
    return (mp, static, rest, fric, x, q, v, w, len(loc)), loc, rad


def _check_material(where: str, restitution: float, friction: float) -> None:
    if not (math.isfinite(restitution) and 0.0 <= restitution <= 1.0):
        raise ConfigError(f"{where}.restitution", restitution, "[0, 1]")
    if not (math.isfinite(friction) and 0.0 <= friction <= 10.0):
        raise ConfigError(f"{where}.friction", friction, "[0, 10]")
