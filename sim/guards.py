"""Runtime guards: a failing simulation becomes a clear error before anything bad is written.

DESIGN.md promise 2: hard cases stay numerically stable, and when they do not, the user learns
what, where and when. Every guard raises a `SandboxError` subclass whose message names the field,
the entity (body, boundary sphere, particle), its index and the step; the envelope the guards
protect is written down in docs/robustness.md (with the test behind each line).

State guards (cheap: one download of the body table, a few numpy reductions):
- `check_state(world, when="end")`: runs after every frame (World.step_frame calls it). Rigid
  bodies (body_v, body_w, body_x, body_q finite, |q| = 1), the elastic particles (particle_x,
  particle_v finite) and, after a fracture event, the particle store (volume > 0, mass > 0,
  finite centroids, finite positive-definite kernel tensors). With `when="start"` the same check
  names the values as changed *between* frames (a caller or a viewer wrote them).
- `install_step_guard(world)`: wraps the world's rigid and elastic `step` so that the state is
  checked before and after every rigid step: a value that turns non-finite is named with the
  exact rigid step (and substep of the frame) in which it appeared.

Input and set-up guards:
- `check_time_step(world_or_effect)`: the elastic time step must not exceed the stable step of
  sph.elastic (dt <= cfl h_min / c_max, and <= 0.7 * 2 / omega_max when the operator was measured);
  the rigid step must lie in (0, 0.1] s. Raises `TimeStepError` (a ConfigError) naming the key.
- `check_scene(cfg)`: what the scene schema cannot see alone: initial speeds above the rigid
  solver's speed clamp (they would be silently cut to `max_speed_mps`), a rigid step above 0.1 s.
- mesh input is guarded in geometry/surface_checks.py (overlapping or folded shells).

Also `state_hash(world)`: SHA-256 of the bodies' poses and velocities and of the particle table,
for determinism checks (stats.json can carry it).
"""

from __future__ import annotations

import hashlib
import math
import weakref

import numpy as np

from core.errors import ConfigError, SandboxError

QUAT_NORM_TOL = 1e-6  # -: |q| may differ from 1 by this much (renormalised every substep)
STABLE_DT_RTOL = 1e-12  # -: relative slack on the stable elastic step (round-off of dt_frame / steps)
RIGID_DT_MAX = 0.1  # s: largest rigid step RigidWorld.step accepts
RIGID_FIELD_ORDER = ("body_v", "body_w", "body_x", "body_q")  # velocities first: positions follow them


class SimulationError(SandboxError):
    """The state became non-finite or unphysical; names the field, the entity and the step.

    Attributes: field (the first bad field, e.g. 'body_v'), fields (every bad field), entity
    ('body', 'particle'), index (the first bad entity), frame, step (rigid or elastic step count).
    """

    def __init__(self, message: str, field: str = "", fields: tuple = (), entity: str = "",
                 index: int = -1, frame: int = -1, step: int = -1) -> None:
        self.field = field
        self.fields = tuple(fields) or ((field,) if field else ())
        self.entity = entity
        self.index = index
        self.frame = frame
        self.step = step
        super().__init__(message)


class TimeStepError(ConfigError):
    """A time step above the stable one: names the key, the value and the stable bound."""


# ---------------------------------------------------------------------------------------- state
def _bad_rows(a: np.ndarray, alive: np.ndarray | None = None) -> np.ndarray:
    a = np.asarray(a)
    bad = ~np.all(np.isfinite(a.reshape(len(a), -1)), axis=1)
    if alive is not None:
        bad &= alive
    return np.flatnonzero(bad)


def _report(kind: str, bad: dict[str, np.ndarray], where: str, frame: int, step: int, order,
            what: str = "non-finite") -> None:
    """Raise one SimulationError for every bad field of `kind` (fields in `order`)."""
    names = [f for f in order if f in bad and len(bad[f])]
    if not names:
        return
    first = names[0]
    index = int(bad[first][0])
    per_field = "; ".join(
        f"{f} of {kind} {', '.join(map(str, bad[f][:5].tolist()))}{' ...' if len(bad[f]) > 5 else ''}"
        f" ({len(bad[f])} {kind}{'s' if len(bad[f]) != 1 else ''})"
        for f in names
    )
    raise SimulationError(
        f"{what} state {where} (frame {frame}, step {step}): {per_field}",
        field=first, fields=tuple(names), entity=kind, index=index, frame=frame, step=step,
    )


def check_rigid(rigid, frame: int = -1, where: str = "") -> None:
    """Body poses and velocities of a RigidWorld are finite and the quaternions unit (alive bodies)."""
    st = rigid.body_state(fresh=True)  # what the store holds, however it was written
    if len(st.alive) == 0:
        return
    bad = {f"body_{k}": _bad_rows(getattr(st, k), st.alive) for k in ("v", "w", "x", "q")}
    qn = np.linalg.norm(st.q, axis=1)
    off = np.flatnonzero(st.alive & np.isfinite(qn) & (np.abs(qn - 1.0) > QUAT_NORM_TOL))
    step = int(rigid.step_count)
    _report("body", bad, where or "after the rigid step", frame, step, RIGID_FIELD_ORDER)
    if off.size:
        raise SimulationError(
            f"body_q of body {off[0]} is not a unit quaternion (|q| = {qn[off[0]]:.9g}, {off.size} bodies) "
            f"{where} (frame {frame}, step {step})",
            field="body_q", entity="body", index=int(off[0]), frame=frame, step=step,
        )


def check_elastic(effect, frame: int = -1, where: str = "") -> None:
    """Positions and velocities of the elastic particles are finite."""
    step = int(round(effect.time / effect.dt)) if effect.dt > 0 else -1
    bad = {"particle_v": _bad_rows(effect.velocities()), "particle_x": _bad_rows(effect.positions())}
    _report("particle", bad, where or "after the elastic step", frame, step, ("particle_v", "particle_x"))


def check_particles(world, frame: int = -1, where: str = "") -> None:
    """Tet particles (after a fracture event), checked on the store by one kernel (nothing copied to
    the host): alive ones have finite geometry, positive volume and mass; kernel tensors are finite
    and positive definite (geometry.particle_store.ParticleStore.first_invalid)."""
    first = world.store.first_invalid()
    bad = {name: np.array([i] if i >= 0 else [], dtype=np.int64) for name, i in first.items()}
    _report("particle", bad, where or "in the particle table", frame, -1, tuple(first),
            what="invalid (non-finite, non-positive or not positive definite)")


_checked_versions: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # world -> surface_version checked


def check_state(world, when: str = "end") -> None:
    """The whole state of a World (see the module docstring). `when`: 'end' (after the frame's
    steps, the default) or 'start' (before them: values changed between frames)."""
    frame = int(world.frame)
    where = "at the end of the frame" if when == "end" else "at the start of the frame (changed between frames)"
    if "rigid" in world.stages:
        check_rigid(world.rigid, frame, where)
    if "elastic" in world.stages:
        check_elastic(world.elastic, frame, where)
    version = int(getattr(world, "surface_version", 0))
    if _checked_versions.get(world) != version:
        check_particles(world, frame, where)
        _checked_versions[world] = version


def install_step_guard(world) -> None:
    """Check the state before and after every rigid and elastic step of `world` (instance wrappers):
    a non-finite value is named with the rigid step, and the substep of the frame, where it appeared."""
    if getattr(world, "_step_guard", False):
        return
    world._step_guard = True
    if "rigid" in world.stages:
        rigid = world.rigid
        inner = rigid.step
        substeps = int(world.cfg.scene.substeps)

        def rigid_step(dt: float, split: bool = True, free: bool = False) -> None:
            sub = rigid.step_count % substeps
            check_rigid(rigid, world.frame, f"before rigid step {rigid.step_count} (substep {sub} of frame "
                                            f"{world.frame}; changed since the previous step)")
            inner(dt, split, free)
            check_rigid(rigid, world.frame, f"in rigid step {rigid.step_count - 1} (substep {sub} of frame "
                                            f"{world.frame})")

        rigid.step = rigid_step
    if "elastic" in world.stages:
        eff = world.elastic
        inner_e = eff.step

        def elastic_step(nsteps: int = 1) -> None:
            check_elastic(eff, world.frame, "before the frame's elastic steps (changed between frames)")
            for _ in range(int(nsteps)):
                inner_e(1)
                check_elastic(eff, world.frame, "in the elastic step")

        eff.step = elastic_step


# ------------------------------------------------------------------------------------ time step
_measured_omega: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # effect -> omega_max (rad/s)


def stable_elastic_dt(effect, measure: bool = True) -> float:
    """The largest stable step (s) of an ElasticEffect: the CFL rule of sph.elastic over the materials
    its particles use, and 0.7 * 2 / omega_max of the discrete operator. An effect built without the
    operator check (explicit dt, or check_operator=False) gets omega_max measured here when `measure`:
    the rule alone is not stable for order-2 gradients on disordered particles (docs/robustness.md)."""
    from sph.elastic import DT_OPERATOR_SAFETY, stable_time_step

    try:
        used = sorted(set(effect.sph.particle_mat.to_numpy().tolist()))
        mats = [effect.materials[k] for k in used]
    except AttributeError:
        mats = list(effect.materials)
    dt = stable_time_step(effect._G0, mats, effect.cfl)
    omega = getattr(effect, "omega_max", None) or _measured_omega.get(effect)
    if omega is None and measure:
        omega = float(effect.max_frequency())
        _measured_omega[effect] = omega
    if omega:
        dt = min(dt, DT_OPERATOR_SAFETY * 2.0 / omega)
    return float(dt)


def check_time_step(target, dt: float | None = None) -> dict:
    """Refuse time steps above the stable ones; returns {'elastic': stable dt, 'rigid': dt} (s).

    target: a World (checks its elastic step `world.elastic.dt` and its rigid step
    1 / (fps * substeps)) or an ElasticEffect (checks `dt`, default its own `dt`).
    """
    out: dict = {}
    effect = target
    if hasattr(target, "stages"):
        world = target
        effect = world.elastic if "elastic" in world.stages else None
        if "rigid" in world.stages:
            sc = world.cfg.scene
            rdt = world.dt_frame / sc.substeps
            if not (math.isfinite(rdt) and 0.0 < rdt <= RIGID_DT_MAX):
                raise TimeStepError("scene.substeps", sc.substeps,
                                    f"a rigid step 1 / (fps x substeps) <= {RIGID_DT_MAX} s (is {rdt:.6g} s)",
                                    world.cfg.source)
            out["rigid"] = rdt
    if effect is not None:
        stable = stable_elastic_dt(effect)
        value = float(effect.dt if dt is None else dt)
        if not (math.isfinite(value) and 0.0 < value <= stable * (1.0 + STABLE_DT_RTOL)):
            from sph.kernel import shortest_axis_np
            from sph.materials import wave_speed_max

            h_min = float(np.min(shortest_axis_np(effect._G0)))
            c_max = max(wave_speed_max(m) for m in effect.materials)
            raise TimeStepError(
                "elastic.dt", value,
                f"0 < dt <= the stable step {stable:.6g} s (cfl {effect.cfl} x shortest kernel axis "
                f"{h_min:.4g} m / wave speed {c_max:.5g} m/s, and 0.7 x 2 / omega_max); "
                f"{value / stable:.3g} x stable",
            )
        out["elastic"] = stable
    return out


def check_neighbourhoods(effect, rel_tol: float = 1e-6, source: str = "elastic") -> None:
    """Refuse an elastic effect with a particle whose neighbours do not span 3D.

    Its deformation gradient F_i = sum_j x_ji (x) d_ij is then rank-deficient: sph.corotated falls
    back to the plain gradient (order 0), the rotation from the polar decomposition of F_i is
    arbitrary, and the corotated forces of such a particle grow without bound (tested: a WPCA plate
    whose kernels are shrunk across the plate). Raises ConfigError naming the particle, its
    neighbour count and the kernel keys to change. Particles with no neighbour at all count too:
    they would leave the body as free points.
    """
    sph = effect.sph
    off = sph.nbr_offset.to_numpy().astype(np.int64)
    idx = sph.nbr_index.to_numpy().astype(np.int64)[: off[-1]]
    x0 = sph.particle_x0.to_numpy().astype(np.float64)
    n = len(off) - 1
    own = np.repeat(np.arange(n), np.diff(off))
    r = x0[idx] - x0[own]
    cov = np.zeros((n, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = np.bincount(own, weights=r[:, a] * r[:, b], minlength=n)
            cov[:, b, a] = cov[:, a, b]
    ev = np.linalg.eigvalsh(cov)
    flat = np.flatnonzero(~(ev[:, 0] > rel_tol * np.maximum(ev[:, 2], 1e-300)))
    if flat.size:
        i = int(flat[0])
        raise ConfigError(
            f"{source}.kernel", f"particle {i} with {int(off[i + 1] - off[i])} neighbours",
            f"kernels whose support holds neighbours in three dimensions around every particle ({flat.size} of {n} "
            "particles have none or only coplanar ones): raise kernel.support or the axis_scale across thin parts",
        )


# ---------------------------------------------------------------------------------------- scene
def check_scene(cfg, max_speed_mps: float | None = None) -> None:
    """Scene values the schema accepts but the solvers would silently change (see module doc)."""
    from rigid.world import RigidConfig

    vmax = RigidConfig().max_speed_mps if max_speed_mps is None else float(max_speed_mps)
    if cfg.has("rigid"):
        rdt = 1.0 / (cfg.scene.fps * cfg.scene.substeps)
        if rdt > RIGID_DT_MAX:
            raise TimeStepError("scene.substeps", cfg.scene.substeps,
                                f">= {math.ceil(1.0 / (RIGID_DT_MAX * cfg.scene.fps))} at fps {cfg.scene.fps:g}: "
                                f"a rigid step 1 / (fps x substeps) <= {RIGID_DT_MAX} s", cfg.source)
        for i, o in enumerate(cfg.objects):
            speed = float(np.linalg.norm(o.velocity))
            if speed > vmax:
                raise ConfigError(f"objects[{i}].velocity", o.velocity,
                                  f"a speed <= {vmax:g} m/s (the rigid solver's speed clamp; is {speed:.6g} m/s)",
                                  cfg.source)


# ----------------------------------------------------------------------------------- determinism
def state_hash(world) -> str:
    """SHA-256 (hex) of the bodies' poses and velocities and of the particle table of a World."""
    h = hashlib.sha256()
    ps = world.particles
    for a in (ps.alive, ps.body, ps.centroid[ps.alive], ps.links):
        h.update(np.ascontiguousarray(a).tobytes())
    if "rigid" in world.stages:
        st = world.rigid.body_state()
        for a in (st.alive, st.x[st.alive], st.q[st.alive], st.v[st.alive], st.w[st.alive]):
            h.update(np.ascontiguousarray(a).tobytes())
    if "elastic" in world.stages:
        h.update(np.ascontiguousarray(world.elastic.positions()).tobytes())
        h.update(np.ascontiguousarray(world.elastic.velocities()).tobytes())
    return h.hexdigest()
