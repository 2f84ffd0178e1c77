"""The `elastic` effect: explicit time integration of deformable SPH particles (DESIGN.md sect. 4).

Forces: corotated SPH, Eq. 1-3 and 7-10 (sph/corotated.py), plus gravity.
Integrator: velocity Verlet (kick-drift-kick), one force evaluation per step:
    v <- (v + dt/2 a) / (1 + dt/2 c);  x <- x + dt v;  a <- f(x)/m + g;  v <- (v + dt/2 a) / (1 + dt/2 c)
with optional mass-proportional damping c (1/s; force -c m v, integrated implicitly so it can
never destabilise). For a target damping ratio zeta of a mode of angular frequency omega use
`damping_for_ratio(zeta, omega)` = 2 zeta omega. Positions and velocities are synchronous at the
end of a step, so the energy bookkeeping (kinetic + strain + gravity potential) is consistent.
Fixed particles (mask) keep their position and zero velocity: Dirichlet boundary conditions;
they still take part in every neighbourhood and carry stress (they are the clamped material).
Time step: dt = cfl * h_min / c_max, h_min the shortest kernel semi-axis over all particles
(1 / lambda_max(G0_i), support radius along the shortest axis), c_max the fastest plane wave
(materials.wave_speed_max). CFL_DEFAULT per gradient order: 0.25 for orders 0-1 (the measured
limit on the beam lattice at h = 2.2 spacings is cfl 0.51), 0.15 for order 2 (measured limit 0.23:
the quadratic operator is about 5x stiffer). On disordered particles the discrete operator can be
much stiffer than the wave speed suggests (order 2 at h = 2.2 spacings with 0.2-spacing jitter:
35x order 1), so unless dt is given the constructor also estimates omega_max of the linearised
operator (power iteration, `max_frequency`) and uses dt = min(rule, DT_OPERATOR_SAFETY * 2/omega_max).
Storage: ti.ndarray and module-level kernels (see sph/corotated.py), so a new effect never recompiles.
Energies (J): kinetic = sum_free m v^2 / 2; strain = sum_i U_i (Eq. 8) + stabilisation energy;
gravity = -sum_free m g . (x - x0) (datum: rest positions, so it is 0 at the start).
"""

import numpy as np
import taichi as ti

from core.errors import ConfigError
from core.runtime import numpy_float
from sph.corotated import (
    CorotatedSPH,
    force_at,
    nd_f,
    nd_i32,
    nd_m3,
    nd_m6,
    nd_v3,
    nd_v6,
    stress_at,
)
from sph.kernel import shortest_axis_np
from sph.materials import Material, wave_speed_max

CFL_DEFAULT = {0: 0.25, 1: 0.25, 2: 0.15}  # per gradient order: dt = cfl * h_min / c_max
STABILISATION_DEFAULT = 0.0  # alpha of the zero-energy-mode stabilisation (sph/corotated.py); off, see notes
DT_OPERATOR_SAFETY = 0.7  # dt <= 0.7 * 2 / omega_max of the discrete operator (power-iteration estimate)


def damping_for_ratio(zeta: float, omega: float) -> float:
    """Mass-proportional damping coefficient (1/s) giving damping ratio zeta at angular frequency omega."""
    return 2.0 * float(zeta) * float(omega)


def stable_time_step(G0: np.ndarray, materials, cfl: float) -> float:
    """dt = cfl * h_min / c_max (s) for kernel tensors G0 (n,3,3) and the materials used."""
    mats = materials if isinstance(materials, list | tuple) else [materials]
    h_min = float(np.min(shortest_axis_np(G0)))
    c_max = max(wave_speed_max(m) for m in mats)
    return cfl * h_min / c_max



@ti.kernel
def _k_accel(
    x: nd_v3, x0: nd_v3, vol: nd_f, mat: nd_i32, Lrot: nd_m3, H: nd_m3, C: nd_m6, off: nd_i32, idx: nd_i32,
    d: nd_v3, q: nd_v6, w: nd_f, r: nd_v3, F: nd_m3, R: nd_m3, gradu: nd_m3, strain: nd_m3, stress: nd_m3,
    energy: nd_f, estab: nd_f, P: nd_m3, tr_off: nd_i32, tr_entry: nd_i32, tr_src: nd_i32, tr_d: nd_v3,
    force: nd_v3, mass: nd_f, fixed: nd_i32, a: nd_v3, g: ti.math.vec3,
    n: ti.i32, quad: ti.template(), stab: ti.template(), green: ti.template(),
):
    """Stress and accelerations at the current positions (no time step)."""
    for i in range(n):
        stress_at(i, x, x0, vol, mat, Lrot, H, C, off, idx, d, q, w, r, F, R, gradu, strain, stress, energy,
                  estab, P, quad, stab, green)
    for j in range(n):
        f = force_at(j, P, d, r, off, tr_off, tr_entry, tr_src, tr_d, stab)
        force[j] = f
        acc = ti.Vector([0.0, 0.0, 0.0])
        if fixed[j] == 0:
            acc = f / mass[j] + g
        a[j] = acc


@ti.kernel
def _k_step(
    x: nd_v3, x0: nd_v3, vol: nd_f, mat: nd_i32, Lrot: nd_m3, H: nd_m3, C: nd_m6, off: nd_i32, idx: nd_i32,
    d: nd_v3, q: nd_v6, w: nd_f, r: nd_v3, F: nd_m3, R: nd_m3, gradu: nd_m3, strain: nd_m3, stress: nd_m3,
    energy: nd_f, estab: nd_f, P: nd_m3, tr_off: nd_i32, tr_entry: nd_i32, tr_src: nd_i32, tr_d: nd_v3,
    force: nd_v3, mass: nd_f, fixed: nd_i32, a: nd_v3, v: nd_v3, g: ti.math.vec3, dt: float, c: float,
    n: ti.i32, quad: ti.template(), stab: ti.template(), green: ti.template(),
):
    """One velocity-Verlet step with implicit mass-proportional damping c (module doc)."""
    for i in range(n):  # kick (dt/2) and drift
        if fixed[i] == 0:
            vi = (v[i] + 0.5 * dt * a[i]) / (1.0 + 0.5 * dt * c)
            v[i] = vi
            x[i] += dt * vi
        else:
            v[i] = ti.Vector([0.0, 0.0, 0.0])
    for i in range(n):  # stress at the new positions
        stress_at(i, x, x0, vol, mat, Lrot, H, C, off, idx, d, q, w, r, F, R, gradu, strain, stress, energy,
                  estab, P, quad, stab, green)
    for j in range(n):  # forces, then kick (dt/2)
        f = force_at(j, P, d, r, off, tr_off, tr_entry, tr_src, tr_d, stab)
        force[j] = f
        if fixed[j] == 0:
            acc = f / mass[j] + g
            a[j] = acc
            v[j] = (v[j] + 0.5 * dt * acc) / (1.0 + 0.5 * dt * c)


@ti.kernel
def _k_energies(
    x: nd_v3, x0: nd_v3, v: nd_v3, mass: nd_f, fixed: nd_i32, energy: nd_f, estab: nd_f, g: ti.math.vec3,
    n: ti.i32,
) -> ti.math.vec3:
    kin = 0.0
    grav = 0.0
    strain = 0.0
    for i in range(n):
        strain += energy[i] + estab[i]
        if fixed[i] == 0:
            kin += 0.5 * mass[i] * v[i].dot(v[i])
            grav -= mass[i] * g.dot(x[i] - x0[i])
    return ti.Vector([kin, strain, grav])


class ElasticEffect:
    """Deformable SPH particles under corotated elastic forces, gravity and boundary conditions.

    x0 (n,3) m; volume (n,) m^3; G0 (n,3,3) or (3,3) 1/m rest kernels; materials: Material or list;
    material_id (n,) into the list; fixed (n,) bool mask; gravity (3,) m/s^2; damping c (1/s);
    cfl or an explicit dt (s); order / stabilisation / green_factor: see CorotatedSPH.
    """

    def __init__(
        self,
        x0: np.ndarray,
        volume: np.ndarray,
        G0: np.ndarray,
        materials,
        material_id: np.ndarray | None = None,
        fixed: np.ndarray | None = None,
        gravity=(0.0, 0.0, -9.81),
        damping: float = 0.0,
        cfl: float | None = None,
        dt: float | None = None,
        order: int = 2,
        stabilisation: float = STABILISATION_DEFAULT,
        green_factor: bool = True,
        check_operator: bool = True,
    ) -> None:
        mats = list(materials) if isinstance(materials, list | tuple) else [materials]
        if not mats or not all(isinstance(m, Material) for m in mats):
            raise ConfigError("elastic.materials", materials, "one or more sph.materials.Material")
        x0 = np.asarray(x0, dtype=np.float64)
        n = x0.shape[0]
        G0 = np.asarray(G0, dtype=np.float64)
        if G0.shape == (3, 3):
            G0 = np.broadcast_to(G0, (n, 3, 3)).copy()
        mid = np.zeros(n, np.int64) if material_id is None else np.asarray(material_id, np.int64)
        cfl = CFL_DEFAULT[order] if cfl is None else float(cfl)
        if not (cfl > 0.0):
            raise ConfigError("elastic.cfl", cfl, "> 0")
        if not (damping >= 0.0):
            raise ConfigError("elastic.damping", damping, ">= 0 (1/s)")
        self.materials = mats
        self._G0 = G0
        self.sph = CorotatedSPH(
            x0, volume, G0, [m.stiffness for m in mats], mid, order=order,
            stabilisation=stabilisation, green_factor=green_factor,
        )
        self.n = n
        used = sorted(set(mid.tolist()))
        self.cfl = cfl
        self.dt = float(dt) if dt is not None else stable_time_step(G0, [mats[k] for k in used], cfl)
        self.damping = float(damping)
        self.time = 0.0
        self.gravity = np.asarray(gravity, dtype=np.float64).reshape(3)
        density = np.array([m.density for m in mats])[mid]
        mass = density * np.asarray(volume, dtype=np.float64).reshape(-1)
        fixed_mask = np.zeros(n, bool) if fixed is None else np.asarray(fixed, bool).reshape(-1)
        if fixed_mask.shape != (n,):
            raise ValueError(f"fixed mask must have shape ({n},)")
        dtp = numpy_float()
        self.particle_mass = ti.ndarray(float, shape=n)  # (n,) kg: mass = density * volume
        self.particle_fixed = ti.ndarray(ti.i32, shape=n)  # (n,) 1: 1 = position prescribed (Dirichlet)
        self.particle_v = ti.ndarray(ti.math.vec3, shape=n)  # (n,) m/s: velocity
        self.particle_a = ti.ndarray(ti.math.vec3, shape=n)  # (n,) m/s^2: acceleration at current positions
        self.particle_mass.from_numpy(mass.astype(dtp))
        self.particle_fixed.from_numpy(fixed_mask.astype(np.int32))
        self.particle_v.from_numpy(np.zeros((n, 3), dtp))
        self.particle_a.from_numpy(np.zeros((n, 3), dtp))
        self.dt_rule = self.dt
        self.omega_max = None
        if check_operator and dt is None and fixed_mask.sum() < n:
            # The CFL rule alone does not bound the discrete operator (order 2 on disordered particles
            # can be 35x stiffer than order 1): never exceed DT_OPERATOR_SAFETY of 2 / omega_max.
            self.omega_max = self.max_frequency()
            if self.omega_max > 0.0:  # 0: no particle sees 3D neighbours; sim.guards.check_neighbourhoods says so
                self.dt = min(self.dt_rule, DT_OPERATOR_SAFETY * 2.0 / self.omega_max)
        self._accelerations()

    @property
    def particle_x(self):
        """(n,) vec3 m: current positions (owned by the CorotatedSPH store)."""
        return self.sph.particle_x

    def release(self) -> None:
        """Drop the device arrays (no field tree is held)."""
        self.sph.release()
        self.particle_mass = self.particle_fixed = self.particle_v = self.particle_a = None

    def _g(self):
        return ti.Vector([float(c) for c in self.gravity])

    def _accelerations(self) -> None:
        s = self.sph
        _k_accel(*s.stress_args, *s.force_args, s.particle_force, self.particle_mass, self.particle_fixed,
                 self.particle_a, self._g(), self.n, *s.flags)

    # ------------------------------------------------------------------ host API

    def step(self, nsteps: int = 1) -> None:
        """Advance nsteps steps of self.dt."""
        s = self.sph
        args = (*s.stress_args, *s.force_args, s.particle_force, self.particle_mass, self.particle_fixed,
                self.particle_a, self.particle_v, self._g(), self.dt, self.damping, self.n, *s.flags)
        nsteps = int(nsteps)
        for _ in range(nsteps):
            _k_step(*args)
        self.time += nsteps * self.dt

    def set_state(self, x: np.ndarray, v: np.ndarray | None = None) -> None:
        """Set positions (and velocities, default 0) and recompute the accelerations."""
        self.sph.set_positions(x)
        vv = np.zeros((self.n, 3)) if v is None else np.asarray(v)
        self.particle_v.from_numpy(np.ascontiguousarray(vv, dtype=numpy_float()))
        self._accelerations()

    def set_gravity(self, g) -> None:
        self.gravity = np.asarray(g, dtype=np.float64).reshape(3)
        self._accelerations()

    def max_frequency(self, iterations: int = 40, seed: int = 0) -> float:
        """Estimate omega_max (rad/s) of the linearised internal forces about the current positions:
        power iteration on M^-1/2 K M^-1/2 (free particles), K v from central differences of the
        forces. Positions are restored. Converges from below; DT_OPERATOR_SAFETY covers the gap."""
        s = self.sph
        x = s.particle_x.to_numpy().astype(np.float64)
        m = self.particle_mass.to_numpy().astype(np.float64)
        free = self.particle_fixed.to_numpy() == 0
        h = float(np.min(shortest_axis_np(self._G0)))
        eps = np.sqrt(float(np.finfo(numpy_float()).eps)) * h
        inv_sqrt_m = (free / np.sqrt(m))[:, None]
        v = np.random.default_rng(seed).standard_normal(x.shape) * free[:, None]
        lam = 0.0
        for _ in range(iterations):
            v /= np.linalg.norm(v)
            dx = eps * v * inv_sqrt_m
            s.set_positions(x + dx)
            fp = s.compute_forces()
            s.set_positions(x - dx)
            fm = s.compute_forces()
            kv = -(fp - fm) / (2.0 * eps) * inv_sqrt_m
            lam = float((v * kv).sum())
            v = kv
        s.set_positions(x)
        return float(np.sqrt(max(lam, 0.0)))

    def energies(self) -> dict:
        """Energies (J) of the current state: kinetic, strain (incl. stabilisation), gravity, total."""
        s = self.sph
        kin, strain, grav = (float(v) for v in _k_energies(
            s.particle_x, s.particle_x0, self.particle_v, self.particle_mass, self.particle_fixed,
            s.particle_energy, s.particle_energy_stab, self._g(), self.n))
        return {"kinetic": kin, "strain": strain, "gravity": grav, "total": kin + strain + grav}

    def positions(self) -> np.ndarray:
        return self.sph.particle_x.to_numpy()

    def velocities(self) -> np.ndarray:
        return self.particle_v.to_numpy()
