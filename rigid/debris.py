"""Debris: the particles a shatter zone frees (Sect. 4.2, r_inner: "break into isolated particles"),
moved as free spheres that fall and collide with the scene's colliders (DESIGN.md section 3,
"Debris"), the `debris` effect.

A debris particle is a point mass with the radius of its tet, r = (3V / 4 pi)^(1/3); it does not
rotate and collides with the static colliders only (planes and oriented boxes), never with bodies
or other debris: thousands of grains cost one small kernel per substep, not contacts in the rigid
solver. Per substep (symplectic Euler, like the rigid bodies): v += g dt, x += v dt; then for each
collider with penetration d < 0 the sphere is moved out along the contact normal and its normal
velocity v_n < 0 is reflected with the collider's restitution e, while Coulomb friction takes up to
mu (1 + e) |v_n| from the tangential speed (an impulse bounded by the normal impulse). Mass is
carried by the particle set (alive, body -1); the store holds only positions and velocities.
"""


import numpy as np
import taichi as ti

from core import field_pool
from core.errors import ConfigError
from core.field_pool import pow2_at_least
from core.runtime import numpy_float

MIN_CAPACITY = 256  # debris slots allocated at least
PLANE, BOX = 0, 1  # collider kinds
# the fields the host copies (debris added, read, given velocities; the colliders), as numpy views of
# their memory on the CPU backend (rigid/host_views.py), by the kernels below elsewhere
VIEWED = ("debris_r", "debris_particle", "debris_x", "debris_v", "col_kind", "col_x", "col_n", "col_rot", "col_half",
          "col_e", "col_mu")


@ti.data_oriented
class _DebrisArrays:
    """The device side of a DebrisStore: its field tree and the kernels over it, recycled through
    core/field_pool.py (never destroyed: that clears every compiled kernel of the program); the kernels
    take `self`, so a recycled one keeps its compiled kernels."""

    def __init__(self, cap: int, ncol: int) -> None:
        vec3, mat3 = ti.math.vec3, ti.math.mat3
        fb = ti.FieldsBuilder()
        # ---- debris: fixed data ----
        self.debris_r = ti.field(float)  # (ND,) m: radius of the particle's tet-volume sphere
        self.debris_particle = ti.field(ti.i32)  # (ND,) -: index of the particle in the ParticleSet
        # ---- debris: changing data ----
        self.debris_x = vec3.field()  # (ND,) m: world position
        self.debris_v = vec3.field()  # (ND,) m/s: velocity
        fb.dense(ti.i, cap).place(self.debris_r, self.debris_particle, self.debris_x, self.debris_v)
        # ---- colliders: fixed data ----
        self.col_kind = ti.field(ti.i32)  # (NC,) -: PLANE or BOX
        self.col_x = vec3.field()  # (NC,) m: a point of the plane, or the box centre
        self.col_n = vec3.field()  # (NC,) -: plane's outward unit normal
        self.col_rot = mat3.field()  # (NC,) -: box orientation (columns: box axes in the world)
        self.col_half = vec3.field()  # (NC,) m: box half extents
        self.col_e = ti.field(float)  # (NC,) -: restitution
        self.col_mu = ti.field(float)  # (NC,) -: Coulomb friction
        fb.dense(ti.i, ncol).place(self.col_kind, self.col_x, self.col_n, self.col_rot, self.col_half,
                                   self.col_e, self.col_mu)
        fb.finalize()
        self.capacity, self.n_col_slots = cap, ncol
        self._views = None  # made at the first use (`views`)

    def views(self) -> dict | None:
        """VIEWED as numpy views of the fields' memory, or None (the kernels copy)."""
        from rigid.host_views import field_views

        if self._views is None:
            self._views = field_views(self, VIEWED, (), self._k_addresses) or {}
        return self._views or None

    @ti.kernel
    def _k_addresses(self, out: ti.types.ndarray()):
        """out[2k], out[2k + 1]: the addresses of rows 0 and 1 of field VIEWED[k]."""
        for k in ti.static(range(len(VIEWED))):
            out[2 * k] = ti.get_addr(ti.static(getattr(self, VIEWED[k])), 0)
            out[2 * k + 1] = ti.get_addr(ti.static(getattr(self, VIEWED[k])), 1)

    @ti.kernel
    def _k_set_colliders(self, n: ti.i32, kind: ti.types.ndarray(), x: ti.types.ndarray(), nrm: ti.types.ndarray(),
                         rot: ti.types.ndarray(), half: ti.types.ndarray(), e: ti.types.ndarray(),
                         mu: ti.types.ndarray()):
        """The colliders' rows from host arrays: one kernel, where a from_numpy per field compiled seven
        (about 0.15 s of every start with debris)."""
        for c in range(n):
            self.col_kind[c] = kind[c]
            self.col_x[c] = ti.math.vec3(x[c, 0], x[c, 1], x[c, 2])
            self.col_n[c] = ti.math.vec3(nrm[c, 0], nrm[c, 1], nrm[c, 2])
            self.col_half[c] = ti.math.vec3(half[c, 0], half[c, 1], half[c, 2])
            for a, b in ti.static(ti.ndrange(3, 3)):
                self.col_rot[c][a, b] = rot[c, a, b]
            self.col_e[c] = e[c]
            self.col_mu[c] = mu[c]

    @ti.kernel
    def _k_set_v(self, k: ti.i32, index: ti.types.ndarray(), v: ti.types.ndarray()):
        for i in range(k):
            self.debris_v[index[i]] = ti.math.vec3(v[i, 0], v[i, 1], v[i, 2])

    @ti.kernel
    def _k_append(self, start: ti.i32, k: ti.i32, x: ti.types.ndarray(), v: ti.types.ndarray(),
                  r: ti.types.ndarray(), pid: ti.types.ndarray()):
        for i in range(k):
            self.debris_x[start + i] = ti.math.vec3(x[i, 0], x[i, 1], x[i, 2])
            self.debris_v[start + i] = ti.math.vec3(v[i, 0], v[i, 1], v[i, 2])
            self.debris_r[start + i] = r[i]
            self.debris_particle[start + i] = pid[i]

    @ti.func
    def _respond(self, i, c, normal, depth):
        """Move debris i out of collider c by `depth` along `normal`; restitution and friction."""
        self.debris_x[i] += depth * normal
        v = self.debris_v[i]
        vn = v.dot(normal)
        if vn < 0.0:
            vt = v - vn * normal
            vt_len = vt.norm()
            cut = self.col_mu[c] * (1.0 + self.col_e[c]) * (-vn)
            scale = 0.0
            if vt_len > cut:
                scale = 1.0 - cut / vt_len
            self.debris_v[i] = scale * vt - self.col_e[c] * vn * normal

    @ti.kernel
    def _k_step(self, n: ti.i32, ncol: ti.i32, dt: float, g: ti.math.vec3):
        for i in range(n):
            self.debris_v[i] += g * dt
            self.debris_x[i] += self.debris_v[i] * dt
            r = self.debris_r[i]
            for c in range(ncol):
                # the contact's normal and depth, then one response (one inlined copy to compile)
                hit = 0
                normal = ti.math.vec3(0.0)
                depth = 0.0
                if self.col_kind[c] == PLANE:
                    nrm = self.col_n[c]
                    d = (self.debris_x[i] - self.col_x[c]).dot(nrm) - r
                    if d < 0.0:
                        hit, normal, depth = 1, nrm, -d
                else:
                    R = self.col_rot[c]
                    h = self.col_half[c]
                    p = R.transpose() @ (self.debris_x[i] - self.col_x[c])
                    q = ti.math.clamp(p, -h, h)
                    gap = p - q
                    dist = gap.norm()
                    if dist > 0.0:
                        if dist < r:
                            hit, normal, depth = 1, R @ (gap / dist), r - dist
                    else:  # centre inside the box: out through the nearest face
                        slack = h - ti.abs(p)
                        k = 0
                        if slack[1] < slack[k]:
                            k = 1
                        if slack[2] < slack[k]:
                            k = 2
                        nl = ti.math.vec3(0.0)
                        nl[k] = 1.0 if p[k] >= 0.0 else -1.0
                        hit, normal, depth = 1, R @ nl, slack[k] + r
                if hit:
                    self._respond(i, c, normal, depth)

    @ti.kernel
    def _k_max_speed(self, n: ti.i32) -> float:
        v = 0.0
        for i in range(n):
            ti.atomic_max(v, self.debris_v[i].norm())
        return v

    @ti.kernel
    def _k_read(self, first: ti.i32, k: ti.i32, x: ti.types.ndarray(), v: ti.types.ndarray(),
                r: ti.types.ndarray(), pid: ti.types.ndarray()):
        for j in range(k):
            for a in ti.static(range(3)):
                x[j, a] = self.debris_x[first + j][a]
                v[j, a] = self.debris_v[first + j][a]
            r[j] = self.debris_r[first + j]
            pid[j] = self.debris_particle[first + j]


def _acquire(capacity: int, n_colliders: int) -> _DebrisArrays:
    key = (pow2_at_least(capacity, MIN_CAPACITY), max(1, n_colliders))
    return field_pool.acquire(("debris", *key), lambda: _DebrisArrays(*key))


def _recycle(arrays: _DebrisArrays) -> None:
    field_pool.recycle(("debris", arrays.capacity, arrays.n_col_slots), arrays)


class DebrisStore:
    """Free debris spheres and the colliders they meet; capacity grows by doubling between frames."""

    def __init__(self, capacity: int, gravity, colliders: list[dict]) -> None:
        self.gravity = ti.math.vec3(*[float(g) for g in gravity])
        self._colliders = list(colliders)
        self.count = 0
        self._a = _acquire(int(capacity), len(self._colliders))
        self._upload_colliders()

    @property
    def capacity(self) -> int:
        return self._a.capacity

    @property
    def debris_x(self):
        """(ND,) m: the device field of world positions (the renderer copies from it)."""
        return self._a.debris_x

    @property
    def debris_r(self):
        """(ND,) m: the device field of radii."""
        return self._a.debris_r

    def _upload_colliders(self) -> None:
        n = max(1, len(self._colliders))
        kind = np.zeros(n, np.int32)
        x, nrm, half = np.zeros((n, 3)), np.tile([0.0, 1.0, 0.0], (n, 1)), np.ones((n, 3))
        rot, e, mu = np.tile(np.eye(3), (n, 1, 1)), np.zeros(n), np.zeros(n)
        for k, c in enumerate(self._colliders):
            kind[k] = PLANE if c["type"] == "plane" else BOX
            x[k] = c["x"]
            if c["type"] == "plane":
                nrm[k] = np.asarray(c["normal"], dtype=np.float64) / np.linalg.norm(c["normal"])
            else:
                half[k] = c["half"]
                rot[k] = c.get("rot", np.eye(3))
            e[k], mu[k] = c["restitution"], c["friction"]
        fdt = numpy_float()
        if (hv := self._a.views()) is not None:
            for name, a in zip(VIEWED[4:], (kind, x, nrm, rot, half, e, mu)):
                hv[name][:n] = a.astype(hv[name].dtype)
        else:
            self._a._k_set_colliders(n, kind, *(a.astype(fdt) for a in (x, nrm, rot, half, e, mu)))
        self.n_colliders = len(self._colliders)

    def release(self) -> None:
        """Give the device arrays back for a later store (the store is unusable afterwards)."""
        if self._a is not None:
            _recycle(self._a)
            self._a = None

    def add(self, x, v, radius, particle) -> None:
        """Append debris at world positions x (K,3) m with velocities v (K,3) m/s, radii (K,) m and
        their particle indices (K,)."""
        x, v = np.asarray(x, dtype=np.float64).reshape(-1, 3), np.asarray(v, dtype=np.float64).reshape(-1, 3)
        r, pid = np.asarray(radius, dtype=np.float64).reshape(-1), np.asarray(particle, dtype=np.int32).reshape(-1)
        k = len(x)
        if not (v.shape == (k, 3) and r.shape == (k,) and pid.shape == (k,)):
            raise ConfigError("debris.add", (x.shape, v.shape, r.shape, pid.shape), "matching (K,3), (K,3), (K,), (K,)")
        if k == 0:
            return
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v)) and np.all(r > 0.0)):
            raise ConfigError("debris.add", "non-finite state or radius <= 0", "finite x, v; r > 0 m")
        if self.count + k > self.capacity:
            self._grow(self.count + k)
        self._append(self.count, x, v, r, pid)
        self.count += k

    def _append(self, start: int, x, v, r, pid) -> None:
        """Rows start.. of the debris from host arrays (K,3) m, (K,3) m/s, (K,) m, (K,)."""
        fdt = numpy_float()  # in the run's precision (no lossy cast inside)
        if (hv := self._a.views()) is not None:
            rows = slice(start, start + len(x))
            for name, a in zip(VIEWED[:4], (r.astype(fdt), pid, x.astype(fdt), v.astype(fdt))):
                hv[name][rows] = a
        else:
            self._a._k_append(start, len(x), x.astype(fdt), v.astype(fdt), r.astype(fdt), pid)

    def warm_pieces(self) -> list:
        """Launchers of every kernel the store launches once debris exists, and of the field copies of
        `state`, each on zero entries, so that the first shattering event does not wait for them
        (sim/warm_up.py runs them)."""
        fdt = numpy_float()
        i1, f1, f3 = np.zeros(1, np.int32), np.zeros(1, fdt), np.zeros((1, 3), fdt)
        physics = [lambda: self._a._k_step(0, self.n_colliders, 0.0, self.gravity), lambda: self._a._k_max_speed(0)]
        if self._a.views() is not None:  # the copies are numpy's: nothing of theirs to compile
            return physics
        return [lambda: self._a._k_append(0, 0, f3, f3, f1, i1), *physics,
                lambda: self._a._k_set_v(0, i1, f3), self.state]

    def set_velocities(self, index, v) -> None:
        """Overwrite the velocities (K,3) m/s of the debris entries `index` (K,) (a striker sweeping
        them along, sim/perforation.py)."""
        index = np.asarray(index, dtype=np.int32).reshape(-1)
        v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
        if len(index) != len(v) or (len(index) and (index.min() < 0 or index.max() >= self.count)):
            raise ConfigError("debris.set_velocities", (len(index), len(v), self.count),
                              "matching lengths and indices below the debris count")
        if len(index) and (hv := self._a.views()) is not None:
            hv["debris_v"][index] = v.astype(numpy_float())
        elif len(index):
            self._a._k_set_v(len(index), index, v.astype(numpy_float()))

    def _grow(self, needed: int) -> None:
        """Bigger arrays (capacity doubles until it fits), the old state copied over."""
        keep = self.state()
        pid = keep["particle"]
        cap = self.capacity
        while cap < needed:
            cap *= 2
        self.release()
        self._a = _acquire(cap, len(self._colliders))
        self._upload_colliders()
        n = self.count
        self.count = 0
        if n:
            self._append(0, keep["x"], keep["v"], keep["r"], pid)
        self.count = n

    def step(self, dt: float) -> None:
        """One substep of gravity, motion and collider contacts for every debris particle."""
        if self.count:
            self._a._k_step(self.count, self.n_colliders, float(dt), self.gravity)

    def max_speed(self) -> float:
        """m/s: the fastest live debris particle (0 with none)."""
        return float(self._a._k_max_speed(self.count)) if self.count else 0.0

    def state(self, first: int = 0) -> dict:
        """Numpy copies of the live debris from entry `first` on (only those rows cross to the host: a
        fracture event reads the entries it made): x (K,3) m, v (K,3) m/s, r (K,) m, particle (K,)."""
        k = max(0, self.count - int(first))
        if (hv := self._a.views()) is not None:
            rows = slice(int(first), int(first) + k)
            return dict(x=hv["debris_x"][rows].astype(np.float64), v=hv["debris_v"][rows].astype(np.float64),
                        r=hv["debris_r"][rows].astype(np.float64), particle=hv["debris_particle"][rows].copy())
        fdt = numpy_float()
        out = dict(x=np.zeros((k, 3), fdt), v=np.zeros((k, 3), fdt), r=np.zeros(k, fdt), particle=np.zeros(k, np.int32))
        self._a._k_read(int(first), k, out["x"], out["v"], out["r"], out["particle"])
        return {key: (a if key == "particle" else a.astype(np.float64)) for key, a in out.items()}


__all__ = ["DebrisStore"]
