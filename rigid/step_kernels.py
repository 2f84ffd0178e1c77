"""The rigid step's kernels (rigid/step.py): its stages, each a `ti.func` in broad_phase.py,
narrow_phase.py, solver.py and islands.py, run as four kernels, one per run of stages that the host
does not interrupt. A kernel's first launch in a process costs Taichi's frontend and an LLVM JIT of
its module (about 30 ms even for a copy kernel, docs/decisions.md "Taichi 1.7.4 facts"): the nine
kernels these stages were cost a start about 0.15 s more than these four. The stages' loops stay
top-level loops of their kernel, in the same order.
Optional stages (support levels, sleeping) are compile-time switches: a scene compiles the variant it
runs. The mass scaling stays a kernel of its own (solver.k_mass_scaling): written as a function inside
a kernel, LLVM fused its multiply-adds differently (Taichi's default fast math), which moved the
scaled contacts' effective masses by their last bit and, through the piles' chaos, the pieces of the
scenes that stack bodies (taichi, Pots); the other stages compile to the same arithmetic as before
(the state hashes of the paper scenes are unchanged)."""

import taichi as ti

from rigid import broad_phase, islands, narrow_phase, solver
from rigid.integrate import integrate_body
from rigid.kernel_math import is_active, vec3


@ti.kernel
def k_broad_phase(s: ti.template(), nb: ti.i32, ns: ti.i32, dt: float, margin: float):
    """Stages 1-2: derived per-step data, then the hashed grid."""
    broad_phase.derive(s, nb, ns, dt)
    broad_phase.fill_grid(s, ns, margin)


@ti.kernel
def k_contacts(s: ti.template(), nb: ti.i32, ns: ti.i32, nc: ti.i32, ncol: ti.i32, margin: float,
               use_warm: ti.i32, warm_factor: float, warm_depth: float, max_levels: ti.i32, levels: ti.template()):
    """Stages 4-6: contacts written and set up, then (`levels`) the support levels."""
    narrow_phase.gather(s, ns, ncol, margin)
    narrow_phase.set_up(s, nc, use_warm, warm_factor, warm_depth)
    if ti.static(levels):
        solver.support_levels(s, nb, nc, max_levels)


@ti.kernel
def k_after_substeps(s: ti.template(), nb: ti.i32, nc: ti.i32, dt: float, pos_iters: ti.i32, slop: float,
                     beta: float, max_corr: float, rest_iters: ti.i32, rest_threshold: float, sleep_lin: float,
                     sleep_ang: float):
    """Stages 8-9: split-impulse position correction, then restitution and the sleep timers."""
    solver.correct_positions(s, nb, nc, dt, pos_iters, slop, beta, max_corr)
    solver.restitute(s, nb, nc, rest_iters, rest_threshold, sleep_lin, sleep_ang, dt)


@ti.kernel
def k_bookkeeping(s: ti.template(), nb: ti.i32, nc: ti.i32, ns: ti.i32, time_to_sleep: float,
                  sleeping: ti.template()):
    """Stages 10-11: contacts saved for the next warm start (and the fastest closing speed among them,
    `RigidWorld.fastest_closing`), then (`sleeping`) the islands' sleep."""
    islands.save_contacts(s, nc, ns)
    fastest_closing(s, nc)
    if ti.static(sleeping):
        islands.sleep_islands(s, nb, nc, time_to_sleep)


@ti.func
def fastest_closing(s: ti.template(), nc: ti.i32):
    """s.max_closing: the largest -vn0 (m/s, pre-solve closing speed) of the contacts that carried impulse,
    0 if none (a maximum: the same whatever the order)."""
    s.max_closing[None] = 0.0
    for c in range(nc):
        if s.ct_ltot[c] > 0.0:
            ti.atomic_max(s.max_closing[None], -s.ct_vn0[c])



# A step in which no contact can be made (rigid/free_flight.py says when) runs what the stages do
# when they find none, through the same functions in loops of the same shape, so that LLVM compiles
# the same arithmetic (the state is the full step's bit for bit): 1's pose at the step start, 7's
# substeps, 9's sleep timers and 11's islands of one body each. No sphere, grid or contact is touched.
@ti.kernel
def k_free_start(s: ti.template(), nb: ti.i32):
    """Stage 1 without the spheres."""
    for b in range(nb):
        broad_phase.derive_body(s, b)


@ti.kernel
def k_free_substep(s: ti.template(), nb: ti.i32, h: float, gx: float, gy: float, gz: float, lin_damp: float,
                   ang_damp: float, max_speed: float, max_rot: float):
    """Stage 7 without contacts (solver.k_substep's body loops)."""
    g = vec3(gx, gy, gz)
    for b in range(nb):
        if is_active(s, b):
            solver.body_forces(s, b, h, g, lin_damp, ang_damp, max_speed, max_rot)
    for b in range(nb):
        if is_active(s, b):
            integrate_body(s, b, h)


@ti.kernel
def k_free_end(s: ti.template(), nb: ti.i32, dt: float, sleep_lin: float, sleep_ang: float, time_to_sleep: float,
               sleeping: ti.template()):
    """Stages 9 and 11 without contacts: sleep timers, then each body an island of its own; the
    warm-start store is marked as holding nothing (the full step would save no contact)."""
    for b in range(nb):
        if is_active(s, b):
            solver.count_slow_time(s, b, dt, sleep_lin, sleep_ang)
    if ti.static(sleeping):
        for b in range(nb):
            if is_active(s, b) and s.body_sleep_time[b] >= time_to_sleep:
                islands.fall_asleep(s, b)
    s.max_closing[None] = 0.0
    s.pc_valid[None] = 0
