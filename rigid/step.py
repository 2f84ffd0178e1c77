"""The rigid step as its stages (DESIGN.md 4 "One frame", 5 "Rigid bodies", paper Sect. 5.3).

Stages, in the order `rigid_step` runs them (Box2D-style named stages; contacts are found once
per step and solved over `substeps` substeps, the "temporal Gauss-Seidel" of Box2D v3 / PhysX TGS):

1. `derive`         world inverse inertia R I^-1 R^T, boundary-sphere world centres, sweep distances
                    (how far each sphere may travel this step), pose at the step start.
2. `fill_grid`      broad phase: hashed uniform grid (count, serial scan, serial scatter: buckets list
                    sphere ids in increasing order, so the result does not depend on thread timing).
3. `k_count`        narrow phase, pass 1: contacts per sphere, serial scan; wake requests.
4. `gather`         narrow phase, pass 2: each sphere writes its partner keys into its CSR segment and
                    sorts them, so contacts are ordered by (sphere a, key b) whatever the grid did.
5. `set_up`         contact geometry (sphere-sphere, sphere-plane, sphere-box), effective masses,
                    pre-solve relative normal speed vn0, warm-start impulses matched by (a, b) key.
6. `support_levels`, support levels (distance from static support over the contact graph) and contact
   `k_mass_scaling` mass scaling of heavy-on-light contacts (see solver.k_mass_scaling).
7. `k_substep` x m  symplectic Euler over h = dt / m: v += g h; warm start; sequential impulses
                    (symmetric sweeps; Coulomb cone on the 2D tangent impulse; non-penetration with
                    a speculative allowance vn >= -gap/h, the gap updated from the bodies' motion since
                    the step start); x += h v; rotation by the Dullweber-Leimkuhler-McLachlan (1997)
                    splitting in the principal frame (exact sub-rotations about the principal axes in
                    the Strang order 1-2-3-2-1), which keeps the world angular momentum exactly and has
                    no energy drift, so a tumbling body keeps L and flips about its intermediate axis.
8. `correct_positions` split-impulse position correction on pseudo velocities (never fed back into v, w).
9. `restitute`      restitution (Box2D v3 "relax/restitution": target vn = -e vn0 for contacts that
                    closed faster than the threshold at the step start and carried impulse), sleep timers.
10. `save_contacts` contacts -> warm-start store.
11. `sleep_islands` islands of touching awake bodies (serial union-find); an island whose every body
                    has been slow for `time_to_sleep` goes to sleep.

Stages 1-2, 4-6 (support levels), 8-9 and 10-11 each run as one kernel (rigid/step_kernels.py: fewer
kernels to compile at a start); 3, 6's mass scaling and 7 are kernels of their own (the host reads 3's
count; 7 runs m times; see step_kernels.py for 6).
Quaternions are w-x-y-z. Body b maps a reference point X to `R(q_b) (X - ref_com_b) + x_b`.
Serial loops (`ti.loop_config(serialize=True)`) keep scans, scatters and the Gauss-Seidel sweeps in a
fixed order: with one CPU thread every run is bitwise identical.

Where they live: broad_phase.py (1-2), narrow_phase.py (3-5), solver.py (6-9, with integrate.py),
islands.py (10-11), their kernels in step_kernels.py; host transfers in transfers.py, shared helpers
in kernel_math.py.
"""

from __future__ import annotations

import math
import time

from rigid import broad_phase, narrow_phase, solver, step_kernels


class StageLaps:
    """Stage timer (Box2D-style profile): with `profile` a dict, adds seconds per stage to it
    (synchronising the device between stages, which costs a little); otherwise does nothing."""

    def __init__(self, profile: dict | None) -> None:
        self.profile = profile
        if profile is not None:
            import taichi as ti

            ti.sync()
            self.t = time.perf_counter()

    def __call__(self, name: str) -> None:
        if self.profile is None:
            return
        import taichi as ti

        ti.sync()
        now = time.perf_counter()
        self.profile[name] = self.profile.get(name, 0.0) + now - self.t
        self.t = now


def travel_splits(world, dt: float) -> int:
    """Parts a step of dt is split into so that no active body moves more than
    `config.max_travel_per_step` of its own bounding radius in one part: contacts are found once
    per part, and a body that jumps many times its size in one can slip through a thin one (a 2 cm
    ball at 200 m/s moves 0.83 m in 1/240 s). 1 for every body of the paper scenes at their speeds."""
    limit = world.config.max_travel_per_step
    if limit <= 0.0 or world._nb == 0:
        return 1
    ratio = broad_phase.k_max_travel(world._s, world._nb, dt, world.body_reach())
    return max(1, math.ceil(ratio / limit))


def rigid_step(world, dt: float, split: bool = True, free: bool = False) -> None:
    """Advance a RigidWorld by dt seconds (dt checked by the caller), in `travel_splits` parts, or in
    one where the caller has split the step already (split=False). `free`: the caller knows that no
    contact can be made in this step (rigid/free_flight.py): the bodies move alone."""
    parts = travel_splits(world, dt) if split else 1
    for _ in range(parts):
        (_free_step if free else _step)(world, dt / parts)
    world._forget_state()  # the bodies moved: the host's copy of their state is stale


def _free_step(world, dt: float) -> None:
    """One step of dt seconds with no contact: the stages of the module doc as they run without one."""
    cfg = world.config
    s, nb, g = world._s, world._nb, cfg.gravity
    step_kernels.k_free_start(s, nb)
    h = dt / cfg.substeps
    for _ in range(cfg.substeps):
        step_kernels.k_free_substep(s, nb, h, float(g[0]), float(g[1]), float(g[2]), cfg.linear_damping_per_s,
                                    cfg.angular_damping_per_s, cfg.max_speed_mps,
                                    cfg.max_rotation_per_step_rad / cfg.substeps)
    step_kernels.k_free_end(s, nb, dt, cfg.sleep_linear_speed_mps, cfg.sleep_angular_speed_radps,
                            cfg.time_to_sleep_s, bool(cfg.sleep_enabled))
    world._nc = 0
    world.time += dt
    world.step_count += 1


def _step(world, dt: float) -> None:
    """One step of dt seconds: the stages of the module doc."""
    cfg = world.config
    nb, ns, ncol = world._nb, world._ns, world._ncol
    if nb == 0:
        world.time += dt
        world.step_count += 1
        return
    g = cfg.gravity
    margin = cfg.speculative_margin_m
    lap = StageLaps(world.profile)
    while True:  # 1-3; the contact store grows when the narrow phase needs more room
        s = world._s
        step_kernels.k_broad_phase(s, nb, ns, dt, margin)  # 1-2
        lap("broad_phase")
        narrow_phase.k_count(s, nb, ns, ncol, margin)
        total = int(s.ct_total[None])
        if total <= s.cap_contacts:
            break
        world._grow(contacts=total)
    s = world._s
    nc = total
    scaling = cfg.mass_ratio_cap > 0.0
    step_kernels.k_contacts(s, nb, ns, nc, ncol, margin, int(cfg.warm_start), cfg.warm_start_factor,  # 4-6
                            cfg.warm_start_max_depth_m, cfg.max_support_levels, scaling)
    if scaling:
        solver.k_mass_scaling(s, nc, cfg.mass_ratio_cap)
    h = dt / cfg.substeps
    lap("narrow_phase")
    for sub in range(cfg.substeps):  # 7
        solver.k_substep(s, nb, nc, h, float(g[0]), float(g[1]), float(g[2]), cfg.linear_damping_per_s,
                         cfg.angular_damping_per_s, cfg.max_speed_mps, cfg.max_rotation_per_step_rad / cfg.substeps,
                         cfg.velocity_iterations, sub % 2)
    lap("solve_integrate")
    step_kernels.k_after_substeps(s, nb, nc, dt, cfg.position_iterations, cfg.linear_slop_m,  # 8-9
                                  cfg.position_correction_rate, cfg.max_correction_speed_mps,
                                  cfg.restitution_iterations, cfg.restitution_threshold_mps,
                                  cfg.sleep_linear_speed_mps, cfg.sleep_angular_speed_radps)
    lap("correct_restitute")
    step_kernels.k_bookkeeping(s, nb, nc, ns, cfg.time_to_sleep_s, bool(cfg.sleep_enabled))  # 10-11
    world._nc = nc
    lap("sleep")
    world.time += dt
    world.step_count += 1


def warm_pieces(world) -> list:
    """The full step's kernels, which the free steps before a first contact leave uncompiled
    (rigid/free_flight.py), as pieces for sim/warm_up.py: each kernel's frontend (core.compile), then
    its first launch on nothing (no body, sphere or contact). Those launches only reset scratch that
    every step sets again (the grid, the contact count, the support levels, the fastest closing), and
    the warm-start flag is put back. The store and the settings are read when a piece runs."""
    from functools import partial

    from core.compile import precompile

    def kernels() -> list:
        cfg, s = world.config, world._s
        g = cfg.gravity
        out = [(step_kernels.k_broad_phase, (s, 0, 0, 0.0, cfg.speculative_margin_m)),
               (narrow_phase.k_count, (s, 0, 0, 0, cfg.speculative_margin_m)),
               (step_kernels.k_contacts, (s, 0, 0, 0, 0, cfg.speculative_margin_m, int(cfg.warm_start),
                                          cfg.warm_start_factor, cfg.warm_start_max_depth_m, cfg.max_support_levels,
                                          cfg.mass_ratio_cap > 0.0)),
               (solver.k_substep, (s, 0, 0, 0.0, float(g[0]), float(g[1]), float(g[2]), 0.0, 0.0, 0.0, 0.0, 0, 0)),
               (step_kernels.k_after_substeps, (s, 0, 0, 0.0, 0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0)),
               (step_kernels.k_bookkeeping, (s, 0, 0, 0, 0.0, bool(cfg.sleep_enabled)))]
        if cfg.mass_ratio_cap > 0.0:
            out.append((solver.k_mass_scaling, (s, 0, cfg.mass_ratio_cap)))
        return out

    def frontend(k: int) -> None:
        kernel, args = kernels()[k]
        precompile(kernel, *args)

    def launch(k: int) -> None:
        kernel, args = kernels()[k]
        valid = int(world.read_scalar("pc_valid"))
        kernel(*args)
        world.write_scalar("pc_valid", valid)

    return [piece for k in range(len(kernels())) for piece in (partial(frontend, k), partial(launch, k))]
