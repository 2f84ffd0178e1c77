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
