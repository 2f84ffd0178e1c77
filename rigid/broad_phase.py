"""Rigid step, stages 1-2 (rigid/step.py): derived per-step data (world inverse inertia, sphere world
centres, sweep distances, the pose at the step start) and the broad phase, a hashed uniform grid in
which each sphere is listed in every cell its box covers (the box: its radius, sweep and half the
speculative margin about its centre, `box_cells`), so the narrow phase looks in the sphere's own
cells only and the cells can be smaller than the largest sphere (count, serial scan, serial scatter:
buckets list sphere ids in increasing order, a sphere's entries side by side, so the result does not
depend on thread timing). Beside each entry the bucket keeps that sphere's centre and reach
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
    s.sum_reach[None] = 0.0
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
        ti.atomic_add(s.sum_reach[None], s.bp_radius[i] + sw)



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


# The grid's cell edge in half-widths of the mean sphere box (two boxes wide): a box covers about
# 1.5^3 = 3.4 cells, and a sphere walks the boxes listed in them. Over Pots' first 61 frames, 4 and 5
# were alike and the fastest; 3 listed more entries, 6 walked more candidates.
CELL_PER_MEAN_HALF_WIDTH = 4.0
ENTRIES_PER_SPHERE = 8  # grid room per sphere: a box no wider than a cell covers at most 2^3 cells


@ti.func
def half_width(s: ti.template(), i, margin):
    """m: half the edge of sphere i's box, its radius + sweep + half the margin (two boxes apart,
    no pair can come within the margin), padded against the rounding of its corners."""
    x = s.bp_x[i]
    far = ti.max(ti.max(ti.abs(x[0]), ti.abs(x[1])), ti.abs(x[2]))
    return (s.bp_radius[i] + s.bp_sweep[i] + 0.5 * margin) * (1.0 + 1e-4) + 1e-6 * (1.0 + far)


@ti.func
def box_cells(s: ti.template(), i, margin, inv_cell):
    """The lowest and highest grid cell (ivec3) that sphere i's box covers. The floor is monotonic, so
    the lowest cell both boxes of a pair cover is the larger of their lowest cells."""
    h = half_width(s, i, margin)
    lo = ti.floor((s.bp_x[i] - h) * inv_cell)
    hi = ti.floor((s.bp_x[i] + h) * inv_cell)
    return ivec3(ti.cast(lo[0], ti.i32), ti.cast(lo[1], ti.i32), ti.cast(lo[2], ti.i32)), \
        ivec3(ti.cast(hi[0], ti.i32), ti.cast(hi[1], ti.i32), ti.cast(hi[2], ti.i32))


@ti.func
def choose_cell(s: ti.template(), ns: ti.i32, margin: float):
    """s.grid_cell: CELL_PER_MEAN_HALF_WIDTH mean half-widths, or, where the boxes would then need
    more entries than the grid holds (a few spheres far larger than the rest), 2.01 of the largest
    half-widths, with which no box covers more than 2 cells a side. The boxes' cells at the first
    choice are kept (bp_cell_lo, bp_cell_hi); fill_grid finds them again only after a fallback."""
    mean = s.sum_reach[None] / ti.max(ns, 1) + 0.5 * margin
    s.grid_cell[None] = CELL_PER_MEAN_HALF_WIDTH * mean
    s.grid_entries[None] = 0
    s.max_half[None] = 0.0
    for i in range(ns):
        lo, hi = box_cells(s, i, margin, 1.0 / s.grid_cell[None])
        s.bp_cell_lo[i] = lo
        s.bp_cell_hi[i] = hi
        d = hi - lo + 1
        ti.atomic_add(s.grid_entries[None], ti.cast(d[0], ti.i64) * d[1] * d[2])
        ti.atomic_max(s.max_half[None], half_width(s, i, margin))
    for _ in range(1):
        if s.grid_entries[None] > ENTRIES_PER_SPHERE * s.cap_spheres:
            s.grid_cell[None] = 2.01 * s.max_half[None]


@ti.func
def fill_grid(s: ti.template(), ns: ti.i32, margin: float):
    # the buckets in use: twice the spheres, rounded up to a power of two (the store has room for twice
    # its capacity), so that clearing and scanning them costs what the spheres do, not the capacity
    for _ in range(1):
        used = 1
        while used < 2 * ns and used < s.grid_size:
            used *= 2
        s.grid_mask[None] = used - 1
    hmask = s.grid_mask[None]
    for h in range(hmask + 1):
        s.grid_count[h] = 0
        s.grid_fill[h] = 0
        s.grid_top[h] = -1
    choose_cell(s, ns, margin)
    for i in range(ns):
        lo, hi = s.bp_cell_lo[i], s.bp_cell_hi[i]  # choose_cell's, at the first choice of cell edge
        if s.grid_entries[None] > ENTRIES_PER_SPHERE * s.cap_spheres:  # the cell fell back: the boxes again
            lo, hi = box_cells(s, i, margin, 1.0 / s.grid_cell[None])
            s.bp_cell_lo[i] = lo
            s.bp_cell_hi[i] = hi
        for cz in range(lo[2], hi[2] + 1):
            for cy in range(lo[1], hi[1] + 1):
                for cx in range(lo[0], hi[0] + 1):
                    ti.atomic_add(s.grid_count[cell_hash(ivec3(cx, cy, cz), hmask)], 1)
    ti.loop_config(serialize=True)
    for h in range(hmask + 1):
        s.grid_start[h + 1] = s.grid_start[h] + s.grid_count[h]
    ti.loop_config(serialize=True)
    for i in range(ns):
        lo, hi = s.bp_cell_lo[i], s.bp_cell_hi[i]
        reach = vec4(s.bp_x[i], s.bp_radius[i] + s.bp_sweep[i])
        for cz in range(lo[2], hi[2] + 1):
            for cy in range(lo[1], hi[1] + 1):
                for cx in range(lo[0], hi[0] + 1):
                    h = cell_hash(ivec3(cx, cy, cz), hmask)
                    at = s.grid_start[h] + s.grid_fill[h]
                    s.grid_entry[at] = i
                    s.grid_reach[at] = reach
                    s.grid_fill[h] = s.grid_fill[h] + 1  # a serial loop: no atomic needed
                    s.grid_top[h] = i  # ids come in increasing order: the last is the bucket's largest
    # a body's spheres hold consecutive ids (RigidWorld appends a body's spheres together and keeps
    # their order when it removes bodies): the narrow phase skips a sphere's own body by its range
    for i in range(ns):
        s.body_sphere_end[s.bp_body[i]] = 0
    for i in range(ns):
        ti.atomic_max(s.body_sphere_end[s.bp_body[i]], i + 1)
