"""Rigid step, stages 1-2 (rigid/step.py): derived per-step data (world inverse inertia, sphere world
centres, sweep distances, the pose at the step start) and the broad phase, a hashed uniform grid
(count, serial scan, serial scatter: buckets list sphere ids in increasing order, so the result does
not depend on thread timing). Beside each id the bucket keeps that sphere's centre and reach
(`grid_reach`), so the narrow phase rejects the candidates that cannot touch from memory it reads in
sequence (docs/decisions.md, "Speed at scale")."""

import taichi as ti

from rigid.kernel_math import (
    is_active,
    ivec3,
    mat3,
    q_to_mat,
    vec3,
    vec4,
)


# --------------------------------------------------------------------------- 2. derived data
@ti.func
def derive_body(s: ti.template(), b):
    """Body b's per-step data: active flag, world inverse inertia, the pose at the step start."""
    s.body_active[b] = 1 if is_active(s, b) else 0
    s.body_wake[b] = 0
    iw = mat3(0.0)
    if s.body_alive[b] == 1 and s.body_static[b] == 0:
        r = q_to_mat(s.body_q[b])
        iw = r @ s.body_inv_inertia[b] @ r.transpose()
    s.body_inv_inertia_world[b] = iw
    s.body_x0[b] = s.body_x[b]
    s.body_r0[b] = q_to_mat(s.body_q[b])
    s.body_dx[b] = vec3(0.0)
    s.body_dr[b] = ti.Matrix.identity(float, 3)
    s.body_pv[b] = vec3(0.0)
    s.body_pw[b] = vec3(0.0)


@ti.func
def derive(s: ti.template(), nb: ti.i32, ns: ti.i32, dt: float):
    for b in range(nb):
        derive_body(s, b)
    s.max_reach[None] = 0.0
    for i in range(ns):
        b = s.bp_body[i]
        lx = q_to_mat(s.body_q[b]) @ s.bp_local[i]
        s.bp_x[i] = s.body_x[b] + lx
        sw = 0.0
        disp = vec3(0.0)
        arc = 0.0
        if s.body_active[b] == 1:
            wdt = s.body_w[b].norm() * dt
            sw = dt * s.body_v[b].norm() + wdt * lx.norm()
            disp = dt * (s.body_v[b] + s.body_w[b].cross(lx))
            arc = 0.5 * wdt * wdt * lx.norm()
        s.bp_sweep[i] = sw
        s.bp_disp[i] = disp
        s.bp_arc[i] = arc
        ti.atomic_max(s.max_reach[None], s.bp_radius[i] + sw)



@ti.kernel
def k_max_travel(s: ti.template(), nb: ti.i32, dt: float, reach: ti.types.ndarray()) -> float:
    """The largest distance an active body's spheres can move in dt, in units of the body's bounding
    radius `reach` (m): (|v| + |w| reach) dt / reach (rigid/step.py splits a step by it)."""
    m = 0.0
    for b in range(nb):
        if is_active(s, b) and reach[b] > 0.0:
            ti.atomic_max(m, dt * (s.body_v[b].norm() / reach[b] + s.body_w[b].norm()))
    return m


# --------------------------------------------------------------------------- 3. broad phase
@ti.func
def cell_hash(c, hmask):
    return ((c[0] * 73856093) ^ (c[1] * 19349663) ^ (c[2] * 83492791)) & hmask


@ti.func
def cell_size(s: ti.template(), margin):
    return 2.0 * s.max_reach[None] + margin


@ti.func
def fill_grid(s: ti.template(), ns: ti.i32, margin: float):
    hmask = s.grid_size - 1
    for h in range(s.grid_size):
        s.grid_count[h] = 0
        s.grid_fill[h] = 0
    for i in range(ns):
        inv = 1.0 / cell_size(s, margin)
        x = s.bp_x[i] * inv
        c = ivec3(
            ti.cast(ti.floor(x[0]), ti.i32), ti.cast(ti.floor(x[1]), ti.i32), ti.cast(ti.floor(x[2]), ti.i32)
        )
        s.bp_cell[i] = c
        h = cell_hash(c, hmask)
        s.bp_hash[i] = h
        ti.atomic_add(s.grid_count[h], 1)
    ti.loop_config(serialize=True)
    for h in range(s.grid_size):
        s.grid_start[h + 1] = s.grid_start[h] + s.grid_count[h]
    ti.loop_config(serialize=True)
    for i in range(ns):
        h = s.bp_hash[i]
        at = s.grid_start[h] + s.grid_fill[h]
        s.grid_entry[at] = i
        s.grid_reach[at] = vec4(s.bp_x[i], s.bp_radius[i] + s.bp_sweep[i])
        s.grid_fill[h] += 1
    # a body's spheres hold consecutive ids (RigidWorld appends a body's spheres together and keeps
    # their order when it removes bodies): the narrow phase skips a sphere's own body by its range
    for i in range(ns):
        s.body_sphere_end[s.bp_body[i]] = 0
    for i in range(ns):
        ti.atomic_max(s.body_sphere_end[s.bp_body[i]], i + 1)
