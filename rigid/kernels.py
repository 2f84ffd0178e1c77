"""Taichi kernels of the rigid step (DESIGN.md 4 "One frame", 5 "Rigid bodies", paper Sect. 5.3).

Stages, in the order `RigidWorld.step` runs them (Box2D-style named stages; contacts are found once
per step and solved over `substeps` substeps, the "temporal Gauss-Seidel" of Box2D v3 / PhysX TGS):

1. `k_derive`       world inverse inertia R I^-1 R^T, boundary-sphere world centres, sweep distances
                    (how far each sphere may travel this step), pose at the step start.
2. `k_grid`         broad phase: hashed uniform grid (count, serial scan, serial scatter: buckets list
                    sphere ids in increasing order, so the result does not depend on thread timing).
3. `k_count`        narrow phase, pass 1: contacts per sphere, serial scan; wake requests.
4. `k_gather`       narrow phase, pass 2: each sphere writes its partner keys into its CSR segment and
                    sorts them, so contacts are ordered by (sphere a, key b) whatever the grid did.
5. `k_setup`        contact geometry (sphere-sphere, sphere-plane, sphere-box), effective masses,
                    pre-solve relative normal speed vn0, warm-start impulses matched by (a, b) key.
6. `k_levels`,      support levels (distance from static support over the contact graph) and contact
   `k_mass_scaling` mass scaling of heavy-on-light contacts (see k_mass_scaling).
7. `k_substep` x m  symplectic Euler over h = dt / m: v += g h; warm start; sequential impulses
                    (symmetric sweeps; Coulomb cone on the 2D tangent impulse; non-penetration with
                    a speculative allowance vn >= -gap/h, the gap updated from the bodies' motion since
                    the step start); x += h v; rotation by the Dullweber-Leimkuhler-McLachlan (1997)
                    splitting in the principal frame (exact sub-rotations about the principal axes in
                    the Strang order 1-2-3-2-1), which keeps the world angular momentum exactly and has
                    no energy drift, so a tumbling body keeps L and flips about its intermediate axis.
8. `k_correct`      split-impulse position correction on pseudo velocities (never fed back into v, w).
9. `k_finish`       restitution (Box2D v3 "relax/restitution": target vn = -e vn0 for contacts that
                    closed faster than the threshold at the step start and carried impulse), sleep timers.
10. `k_save_prev`   contacts -> warm-start store.
11. `k_sleep`       islands of touching awake bodies (serial union-find); an island whose every body
                    has been slow for `time_to_sleep` goes to sleep.

Quaternions are w-x-y-z. Body b maps a reference point X to `R(q_b) (X - ref_com_b) + x_b`.
Serial loops (`ti.loop_config(serialize=True)`) keep scans, scatters and the Gauss-Seidel sweeps in a
fixed order: with one CPU thread every run is bitwise identical.
"""

import taichi as ti

vec3 = ti.math.vec3
vec4 = ti.math.vec4
mat3 = ti.math.mat3
ivec3 = ti.math.ivec3

BIG = 1.0e30  # a float larger than any time or distance in a scene


# --------------------------------------------------------------------------- quaternion helpers
@ti.func
def q_mul(a, b):
    return vec4(
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    )


@ti.func
def q_conj(q):
    return vec4(q[0], -q[1], -q[2], -q[3])


@ti.func
def q_to_mat(q):
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ti.Matrix(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@ti.func
def q_exp(rv):
    """Quaternion of the rotation vector rv (axis * angle)."""
    th = rv.norm()
    res = vec4(1.0, 0.0, 0.0, 0.0)
    if th > 1e-300:
        s = ti.sin(0.5 * th) / th
        res = vec4(ti.cos(0.5 * th), s * rv[0], s * rv[1], s * rv[2])
    return res


@ti.func
def q_normalized(q):
    return q / q.norm()


# --------------------------------------------------------------------------- body predicates
@ti.func
def is_active(s: ti.template(), b):
    """Alive, dynamic and awake now."""
    return s.body_alive[b] == 1 and s.body_static[b] == 0 and s.body_asleep[b] == 0


@ti.func
def tangents(n):
    t1 = vec3(0.0)
    if ti.abs(n[0]) < 0.57735:
        t1 = vec3(0.0, n[2], -n[1])  # n x e_x
    else:
        t1 = vec3(-n[2], 0.0, n[0])  # n x e_y
    t1 = t1 / t1.norm()
    return t1, n.cross(t1)


# --------------------------------------------------------------------------- 1. forces
@ti.func
def body_forces(s: ti.template(), b, h, g, lin_damp, ang_damp, max_speed, max_rot):
    """Symplectic Euler, velocity part: v += g h, damping, speed clamps."""
    v = (s.body_v[b] + h * g) / (1.0 + h * lin_damp)
    w = s.body_w[b] / (1.0 + h * ang_damp)
    sp = v.norm()
    if sp > max_speed:
        v *= max_speed / sp
    wn = w.norm()
    if wn * h > max_rot:
        w *= max_rot / (wn * h)
    s.body_v[b] = v
    s.body_w[b] = w


# --------------------------------------------------------------------------- 2. derived data
@ti.kernel
def k_derive(s: ti.template(), nb: ti.i32, ns: ti.i32, dt: float):
    for b in range(nb):
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


# --------------------------------------------------------------------------- 3. broad phase
@ti.func
def cell_hash(c, hmask):
    return ((c[0] * 73856093) ^ (c[1] * 19349663) ^ (c[2] * 83492791)) & hmask


@ti.func
def cell_size(s: ti.template(), margin):
    return 2.0 * s.max_reach[None] + margin


@ti.kernel
def k_grid(s: ti.template(), ns: ti.i32, margin: float):
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
        s.grid_entry[s.grid_start[h] + s.grid_fill[h]] = i
        s.grid_fill[h] += 1


# --------------------------------------------------------------------------- 4-5. narrow phase
@ti.func
def collider_gap(s: ti.template(), k, x, r):
    """Signed gap (m), unit normal from the collider towards the sphere, and the collider's surface point."""
    n = vec3(0.0, 1.0, 0.0)
    gap = 0.0
    surf = x
    if s.col_kind[k] == 0:
        n = s.col_n[k]
        d = (x - s.col_x[k]).dot(n)
        gap = d - r
        surf = x - d * n
    else:
        rot = q_to_mat(s.col_q[k])
        hlf = s.col_half[k]
        xl = rot.transpose() @ (x - s.col_x[k])
        ql = ti.max(ti.min(xl, hlf), -hlf)
        dl = xl - ql
        dist = dl.norm()
        if dist > 0.0:
            n = rot @ (dl / dist)
            gap = dist - r
            surf = s.col_x[k] + rot @ ql
        else:
            # centre inside the box: push out through the nearest face
            best = BIG
            axis = 0
            sgn = 1.0
            for a in ti.static(range(3)):
                depth = hlf[a] - ti.abs(xl[a])
                if depth < best:
                    best = depth
                    axis = a
                    sgn = 1.0 if xl[a] >= 0.0 else -1.0
            nl = vec3(0.0)
            nl[axis] = sgn
            n = rot @ nl
            gap = -best - r
            fl = xl
            fl[axis] = sgn * hlf[axis]
            surf = s.col_x[k] + rot @ fl
    return gap, n, surf


@ti.func
def scan_sphere(s: ti.template(), i, ncol, margin, write: ti.template()):
    """Contacts of sphere i: colliders (if its body is active) and spheres j > i of other bodies.

    write=False counts them and raises wake requests; write=True writes keys into i's segment.
    """
    hmask = s.grid_size - 1
    cnt = 0
    base = 0
    if ti.static(write):
        base = s.bp_ct_start[i]
    bi = s.bp_body[i]
    ai = s.body_active[bi]
    xi = s.bp_x[i]
    ri = s.bp_radius[i]
    swi = s.bp_sweep[i]
    if ai == 1:
        for k in range(ncol):
            gap, _n, _p = collider_gap(s, k, xi, ri)
            if gap < margin + swi:
                if ti.static(write):
                    s.ct_a[base + cnt] = i
                    s.ct_b[base + cnt] = -1 - k
                cnt += 1
    ci = s.bp_cell[i]
    cell = cell_size(s, margin)
    # farthest centre of a partner, padded against the rounding of the cell assignment
    reach = (ri + swi + margin + s.max_reach[None]) * (1.0 + 1e-5) + 1e-5 * cell
    for dz in range(-1, 2):
        for dy in range(-1, 2):
            for dx in range(-1, 2):
                cn = ci + ivec3(dx, dy, dz)
                # skip neighbour cells whose box is out of reach (most of the 27)
                lo = vec3(cn[0], cn[1], cn[2]) * cell
                gap_box = ti.max(ti.max(lo - xi, xi - (lo + cell)), 0.0)
                if gap_box.norm_sqr() > reach * reach:
                    continue
                h = cell_hash(cn, hmask)
                for e in range(s.grid_start[h], s.grid_start[h + 1]):
                    j = s.grid_entry[e]
                    cj = s.bp_cell[j]
                    if j > i and cj[0] == cn[0] and cj[1] == cn[1] and cj[2] == cn[2]:
                        bj = s.bp_body[j]
                        aj = s.body_active[bj]
                        if bj != bi and (ai == 1 or aj == 1):
                            gap = (xi - s.bp_x[j]).norm() - ri - s.bp_radius[j]
                            # speculative by RELATIVE motion: how far the pair can close this step; the
                            # absolute sweeps (swi + sweep_j) only bound it, and pieces of a body that
                            # just split move together (the grid search above keeps using the bound)
                            closing = (s.bp_disp[i] - s.bp_disp[j]).norm() + s.bp_arc[i] + s.bp_arc[j]
                            if gap < margin + ti.min(closing, swi + s.bp_sweep[j]):
                                if ti.static(write):
                                    s.ct_a[base + cnt] = i
                                    s.ct_b[base + cnt] = j
                                else:
                                    # a moving body wakes a sleeping one it touches ("a hit wakes them")
                                    if ai == 1 and s.body_asleep[bj] == 1 and s.body_sleep_time[bi] == 0.0:
                                        s.body_wake[bj] = 1
                                    if aj == 1 and s.body_asleep[bi] == 1 and s.body_sleep_time[bj] == 0.0:
                                        s.body_wake[bi] = 1
                                cnt += 1
    return cnt


@ti.kernel
def k_count(s: ti.template(), nb: ti.i32, ns: ti.i32, ncol: ti.i32, margin: float):
    for i in range(ns):
        s.bp_ct_start[i + 1] = scan_sphere(s, i, ncol, margin, False)
    s.bp_ct_start[0] = 0
    ti.loop_config(serialize=True)
    for i in range(ns):
        s.bp_ct_start[i + 1] += s.bp_ct_start[i]
    s.ct_total[None] = s.bp_ct_start[ns]
    for b in range(nb):
        if s.body_wake[b] == 1:
            s.body_asleep[b] = 0
            s.body_sleep_time[b] = 0.0


@ti.kernel
def k_gather(s: ti.template(), ns: ti.i32, ncol: ti.i32, margin: float):
    for i in range(ns):
        cnt = scan_sphere(s, i, ncol, margin, True)
        base = s.bp_ct_start[i]
        # insertion sort of the segment by key b: contact order independent of the grid layout
        for u in range(1, cnt):
            key = s.ct_b[base + u]
            v = u - 1
            while v >= 0 and s.ct_b[base + v] > key:
                s.ct_b[base + v + 1] = s.ct_b[base + v]
                v -= 1
            s.ct_b[base + v + 1] = key


# --------------------------------------------------------------------------- 6. contact set-up
@ti.func
def point_velocity(s: ti.template(), b, r):
    res = vec3(0.0)
    if b >= 0:
        res = s.body_v[b] + s.body_w[b].cross(r)
    return res


@ti.func
def eff_mass(ima, imb, iwa, iwb, ra, rb, d):
    rad = ra.cross(d)
    rbd = rb.cross(d)
    k = ima + imb + (iwa @ rad).dot(rad) + (iwb @ rbd).dot(rbd)
    res = 0.0
    if k > 0.0:
        res = 1.0 / k
    return res


@ti.kernel
def k_setup(s: ti.template(), nc: ti.i32, use_warm: ti.i32, warm_factor: float):
    for c in range(nc):
        i = s.ct_a[c]
        key = s.ct_b[c]
        ba = s.bp_body[i]
        xi = s.bp_x[i]
        ri = s.bp_radius[i]
        bb = -1
        n = vec3(0.0, 1.0, 0.0)
        gap = 0.0
        p = xi
        mu = 0.0
        e = 0.0
        if key >= 0:
            bb = s.bp_body[key]
            d = xi - s.bp_x[key]
            dist = d.norm()
            rj = s.bp_radius[key]
            if dist > 1e-9 * (ri + rj):
                n = d / dist
            else:
                # coincident centres: separate along the line of the centres of mass
                dc = s.body_x[ba] - s.body_x[bb]
                if dc.norm() > 0.0:
                    n = dc / dc.norm()
            gap = dist - ri - rj
            p = 0.5 * ((xi - ri * n) + (s.bp_x[key] + rj * n))
            mu = ti.sqrt(s.body_friction[ba] * s.body_friction[bb])
            e = ti.max(s.body_restitution[ba], s.body_restitution[bb])
        else:
            k = -1 - key
            cgap, nn, surf = collider_gap(s, k, xi, ri)
            gap = cgap
            n = nn
            p = 0.5 * ((xi - ri * n) + surf)
            mu = ti.sqrt(s.body_friction[ba] * s.col_friction[k])
            e = ti.max(s.body_restitution[ba], s.col_restitution[k])
        ra = p - s.body_x[ba]
        rb = vec3(0.0)
        ima = 0.0
        imb = 0.0
        iwa = mat3(0.0)
        iwb = mat3(0.0)
        if is_active(s, ba):
            ima = s.body_inv_mass[ba]
            iwa = s.body_inv_inertia_world[ba]
        if bb >= 0:
            rb = p - s.body_x[bb]
            if is_active(s, bb):
                imb = s.body_inv_mass[bb]
                iwb = s.body_inv_inertia_world[bb]
        t1, t2 = tangents(n)
        s.ct_body_a[c] = ba
        s.ct_body_b[c] = bb
        s.ct_n[c] = n
        s.ct_p[c] = p
        s.ct_ra[c] = ra
        s.ct_rb[c] = rb
        s.ct_t1[c] = t1
        s.ct_t2[c] = t2
        s.ct_sep[c] = gap
        s.ct_ima[c] = ima
        s.ct_imb[c] = imb
        s.ct_sa[c] = 1.0
        s.ct_sb[c] = 1.0
        s.ct_mn[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, n)
        s.ct_mt1[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, t1)
        s.ct_mt2[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, t2)
        s.ct_vn0[c] = (point_velocity(s, ba, ra) - point_velocity(s, bb, rb)).dot(n)
        s.ct_mu[c] = mu
        s.ct_e[c] = e
        ln = 0.0
        lt = vec3(0.0)
        if use_warm == 1 and s.pc_valid[None] == 1:
            for q in range(s.bp_pc_start[i], s.bp_pc_start[i + 1]):
                if s.pc_b[q] == key:
                    ln = warm_factor * s.pc_ln[q]
                    lt = warm_factor * s.pc_lt[q]
        s.ct_ln[c] = ln
        s.ct_lmax[c] = ln
        s.ct_ltot[c] = 0.0
        s.ct_lt1[c] = lt.dot(t1)
        s.ct_lt2[c] = lt.dot(t2)
        s.ct_lp[c] = 0.0


# --------------------------------------------------------------------------- 7. solver
@ti.func
def apply_impulse(s: ti.template(), c, imp):
    a = s.ct_body_a[c]
    if s.ct_ima[c] > 0.0:
        s.body_v[a] += s.ct_ima[c] * imp
        s.body_w[a] += s.ct_sa[c] * (s.body_inv_inertia_world[a] @ s.ct_ra[c].cross(imp))
    b = s.ct_body_b[c]
    if b >= 0 and s.ct_imb[c] > 0.0:
        s.body_v[b] -= s.ct_imb[c] * imp
        s.body_w[b] -= s.ct_sb[c] * (s.body_inv_inertia_world[b] @ s.ct_rb[c].cross(imp))


@ti.func
def apply_pseudo(s: ti.template(), c, imp):
    a = s.ct_body_a[c]
    if s.ct_ima[c] > 0.0:
        s.body_pv[a] += s.ct_ima[c] * imp
        s.body_pw[a] += s.ct_sa[c] * (s.body_inv_inertia_world[a] @ s.ct_ra[c].cross(imp))
    b = s.ct_body_b[c]
    if b >= 0 and s.ct_imb[c] > 0.0:
        s.body_pv[b] -= s.ct_imb[c] * imp
        s.body_pw[b] -= s.ct_sb[c] * (s.body_inv_inertia_world[b] @ s.ct_rb[c].cross(imp))


@ti.func
def rel_velocity(s: ti.template(), c):
    return point_velocity(s, s.ct_body_a[c], s.ct_ra[c]) - point_velocity(s, s.ct_body_b[c], s.ct_rb[c])


@ti.func
def rel_pseudo_velocity(s: ti.template(), c):
    a = s.ct_body_a[c]
    b = s.ct_body_b[c]
    res = s.body_pv[a] + s.body_pw[a].cross(s.ct_ra[c])
    if b >= 0:
        res -= s.body_pv[b] + s.body_pw[b].cross(s.ct_rb[c])
    return res


@ti.func
def current_gap(s: ti.template(), c):
    """Gap of contact c now: the start gap plus the motion of both anchors along the fixed normal."""
    a = s.ct_body_a[c]
    b = s.ct_body_b[c]
    ra = s.ct_ra[c]
    d = s.body_dx[a] + s.body_dr[a] @ ra - ra
    if b >= 0:
        rb = s.ct_rb[c]
        d -= s.body_dx[b] + s.body_dr[b] @ rb - rb
    return s.ct_sep[c] + d.dot(s.ct_n[c])


LEVEL_NONE = 1 << 30  # support level of a body not resting on anything static


@ti.func
def support_level(s: ti.template(), b):
    """-1 for static support (collider, static or sleeping body), else the body's level."""
    lv = -1
    if b >= 0:
        if is_active(s, b):
            lv = s.body_level[b]
    return lv


@ti.kernel
def k_levels(s: ti.template(), nb: ti.i32, nc: ti.i32, max_levels: ti.i32):
    """Support levels for contact mass scaling: breadth-first distance, over this step's contacts, from
    static support (level 0 = touches a collider, a static or a sleeping body)."""
    for b in range(nb):
        s.body_level[b] = LEVEL_NONE
    s.max_level[None] = -1
    ti.loop_config(serialize=True)
    for _pass in range(max_levels + 1):
        changed = 0
        for c in range(nc):
            a = s.ct_body_a[c]
            b = s.ct_body_b[c]
            la = support_level(s, a)
            lb = support_level(s, b)
            if la > lb + 1 and lb < max_levels:
                s.body_level[a] = lb + 1
                changed = 1
            if lb > la + 1 and la < max_levels:
                s.body_level[b] = la + 1
                changed = 1
        if changed == 0:
            break
    ti.loop_config(serialize=True)
    for b in range(nb):
        if s.body_level[b] != LEVEL_NONE:
            s.max_level[None] = ti.max(s.max_level[None], s.body_level[b])


@ti.kernel
def k_mass_scaling(s: ti.template(), nc: ti.i32, ratio_cap: float):
    """Contact mass scaling for heavy-on-light contacts (PhysX-style inverse-mass scales).

    Sequential impulses converge slowly when a heavy body rests on a light one (the error shrinks by
    about a factor 1 - m_light / m_heavy per pass). Where the upper body (higher support level) is
    more than `ratio_cap` times heavier than the lower one, the lower body's inverse mass and inertia
    in that contact are scaled by gamma = ratio_cap m_lower / m_upper: the pair is solved as if its
    mass ratio were ratio_cap. Contacts of bodies on one level, of free bodies (no static support)
    and with lighter upper bodies are untouched, so momentum is exact there; elsewhere the lower body
    feels only a gamma share of the load above (its friction with the ground is underestimated).
    """
    for c in range(nc):
        a = s.ct_body_a[c]
        b = s.ct_body_b[c]
        if b >= 0 and s.ct_ima[c] > 0.0 and s.ct_imb[c] > 0.0:
            la = s.body_level[a]
            lb = s.body_level[b]
            if la != lb and la != LEVEL_NONE and lb != LEVEL_NONE:
                ratio = s.ct_ima[c] / s.ct_imb[c]  # m_b / m_a
                ga = 1.0
                gb = 1.0
                if la < lb and ratio > ratio_cap:  # a below, b heavier
                    ga = ratio_cap / ratio
                if lb < la and 1.0 / ratio > ratio_cap:  # b below, a heavier
                    gb = ratio_cap * ratio
                if ga < 1.0 or gb < 1.0:
                    s.ct_sa[c] = ga
                    s.ct_sb[c] = gb
                    ima = ga * s.ct_ima[c]
                    imb = gb * s.ct_imb[c]
                    s.ct_ima[c] = ima
                    s.ct_imb[c] = imb
                    iwa = ga * s.body_inv_inertia_world[a]
                    iwb = gb * s.body_inv_inertia_world[b]
                    ra = s.ct_ra[c]
                    rb = s.ct_rb[c]
                    s.ct_mn[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, s.ct_n[c])
                    s.ct_mt1[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, s.ct_t1[c])
                    s.ct_mt2[c] = eff_mass(ima, imb, iwa, iwb, ra, rb, s.ct_t2[c])


@ti.kernel
def k_substep(
    s: ti.template(),
    nb: ti.i32,
    nc: ti.i32,
    h: float,
    gx: float,
    gy: float,
    gz: float,
    lin_damp: float,
    ang_damp: float,
    max_speed: float,
    max_rot: float,
    vel_iters: ti.i32,
    parity: ti.i32,
):
    """One substep of length h (TGS: contacts found once per step, solved every substep)."""
    g = vec3(gx, gy, gz)
    for b in range(nb):
        if is_active(s, b):
            body_forces(s, b, h, g, lin_damp, ang_damp, max_speed, max_rot)
    # warm start: re-apply the accumulated impulses (last substep's, or last step's matched contacts)
    ti.loop_config(serialize=True)
    for c in range(nc):
        apply_impulse(s, c, s.ct_ln[c] * s.ct_n[c] + s.ct_lt1[c] * s.ct_t1[c] + s.ct_lt2[c] * s.ct_t2[c])
    # velocity iterations: friction (cone clamp on the 2D tangent impulse), then the normal
    ti.loop_config(serialize=True)
    for it in range(vel_iters):
        for cc in range(nc):
            # symmetric Gauss-Seidel: alternate the sweep direction so that no contact order is favoured
            c = cc if (it + parity) % 2 == 0 else nc - 1 - cc
            n = s.ct_n[c]
            t1 = s.ct_t1[c]
            t2 = s.ct_t2[c]
            dv = rel_velocity(s, c)
            l1 = s.ct_lt1[c] - s.ct_mt1[c] * dv.dot(t1)
            l2 = s.ct_lt2[c] - s.ct_mt2[c] * dv.dot(t2)
            lim = s.ct_mu[c] * s.ct_ln[c]
            mag = ti.sqrt(l1 * l1 + l2 * l2)
            if mag > lim:
                sc = lim / mag if mag > 0.0 else 0.0
                l1 *= sc
                l2 *= sc
            apply_impulse(s, c, (l1 - s.ct_lt1[c]) * t1 + (l2 - s.ct_lt2[c]) * t2)
            s.ct_lt1[c] = l1
            s.ct_lt2[c] = l2
            # normal: vn >= -gap/h while the gap is open (speculative), vn >= 0 when touching
            vn = rel_velocity(s, c).dot(n)
            bias = ti.max(current_gap(s, c), 0.0) / h
            ln = ti.max(s.ct_ln[c] - s.ct_mn[c] * (vn + bias), 0.0)
            apply_impulse(s, c, (ln - s.ct_ln[c]) * n)
            s.ct_ln[c] = ln
            s.ct_lmax[c] = ti.max(s.ct_lmax[c], ln)
    for c in range(nc):
        s.ct_ltot[c] += s.ct_ln[c]
    for b in range(nb):
        if is_active(s, b):
            integrate_body(s, b, h)


@ti.kernel
def k_correct(
    s: ti.template(),
    nb: ti.i32,
    nc: ti.i32,
    dt: float,
    pos_iters: ti.i32,
    slop: float,
    beta: float,
    max_corr: float,
):
    """Split-impulse position correction, once per step after the substeps (Catto's split impulse,
    as in Bullet): pseudo velocities push penetrating contacts apart by `beta` of the depth beyond the
    slop, then move the bodies; they never enter v and w, so no kinetic energy is added. The
    rotation carries w with the body (body-frame w unchanged: kinetic energy unchanged). Run per
    substep instead, the pseudo rotations of a body resting on a few spheres pumped a rocking mode."""
    for b in range(nb):
        s.body_pv[b] = vec3(0.0)
        s.body_pw[b] = vec3(0.0)
    for c in range(nc):
        s.ct_lp[c] = 0.0
    ti.loop_config(serialize=True)
    for it in range(pos_iters):
        for cc in range(nc):
            c = cc if it % 2 == 0 else nc - 1 - cc
            n = s.ct_n[c]
            target = ti.min(beta * ti.max(-current_gap(s, c) - slop, 0.0) / dt, max_corr)
            vpn = rel_pseudo_velocity(s, c).dot(n)
            lp = ti.max(s.ct_lp[c] + s.ct_mn[c] * (target - vpn), 0.0)
            apply_pseudo(s, c, (lp - s.ct_lp[c]) * n)
            s.ct_lp[c] = lp
    for b in range(nb):
        if is_active(s, b):
            s.body_x[b] += dt * s.body_pv[b]
            pw = s.body_pw[b]
            if pw.norm() > 0.0:
                dq = q_exp(dt * pw)
                s.body_q[b] = q_normalized(q_mul(dq, s.body_q[b]))
                s.body_w[b] = q_to_mat(dq) @ s.body_w[b]


@ti.kernel
def k_finish(
    s: ti.template(),
    nb: ti.i32,
    nc: ti.i32,
    rest_iters: ti.i32,
    rest_threshold: float,
    sleep_lin: float,
    sleep_ang: float,
    dt: float,
):
    """Restitution (Box2D v3 style, after the substeps): target vn = -e vn0 for contacts that closed
    faster than the threshold at the step start and carried impulse; then the sleep timers."""
    ti.loop_config(serialize=True)
    for _it in range(rest_iters):
        for c in range(nc):
            if s.ct_vn0[c] < -rest_threshold and s.ct_lmax[c] > 0.0 and s.ct_e[c] > 0.0:
                n = s.ct_n[c]
                vn = rel_velocity(s, c).dot(n)
                dl = ti.max(-s.ct_mn[c] * (vn + s.ct_e[c] * s.ct_vn0[c]), -s.ct_ltot[c])
                apply_impulse(s, c, dl * n)
                s.ct_ltot[c] += dl
    for b in range(nb):
        if is_active(s, b):
            if s.body_v[b].norm() < sleep_lin and s.body_w[b].norm() < sleep_ang:
                s.body_sleep_time[b] += dt
            else:
                s.body_sleep_time[b] = 0.0


# --------------------------------------------------------------------------- 8. integrate positions
@ti.func
def rotate_about_axis(u, k: ti.template(), ang):
    """Rotate vector u by angle `ang` about coordinate axis k."""
    i = (k + 1) % 3
    j = (k + 2) % 3
    c = ti.cos(ang)
    sn = ti.sin(ang)
    res = u
    res[i] = c * u[i] - sn * u[j]
    res[j] = sn * u[i] + c * u[j]
    return res


@ti.func
def integrate_body(s: ti.template(), b, h):
    """Symplectic Euler, position part, over h; updates the displacement since the step start."""
    w = s.body_w[b]
    s.body_x[b] += h * s.body_v[b]
    q = s.body_q[b]
    # free rotation, DLM splitting in the principal frame; world L is kept exactly
    qw = q_mul(q, s.body_principal_q[b])
    inv_i = s.body_inv_principal[b]
    wp = q_to_mat(qw).transpose() @ w
    lp = vec3(wp[0] / inv_i[0], wp[1] / inv_i[1], wp[2] / inv_i[2])
    for k, f in ti.static([(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)]):
        th = f * h * lp[k] * inv_i[k]
        e = vec3(0.0)
        e[k] = ti.sin(0.5 * th)
        qw = q_mul(qw, vec4(ti.cos(0.5 * th), e[0], e[1], e[2]))
        lp = rotate_about_axis(lp, k, -th)
    qw = q_normalized(qw)
    qn = q_normalized(q_mul(qw, q_conj(s.body_principal_q[b])))
    s.body_q[b] = qn
    s.body_w[b] = q_to_mat(qw) @ (inv_i * lp)
    s.body_dx[b] = s.body_x[b] - s.body_x0[b]
    s.body_dr[b] = q_to_mat(qn) @ s.body_r0[b].transpose()


# --------------------------------------------------------------------------- 9-10. bookkeeping
@ti.kernel
def k_save_prev(s: ti.template(), nc: ti.i32, ns: ti.i32):
    for c in range(nc):
        s.pc_b[c] = s.ct_b[c]
        s.pc_ln[c] = s.ct_ln[c]
        s.pc_lt[c] = s.ct_lt1[c] * s.ct_t1[c] + s.ct_lt2[c] * s.ct_t2[c]
    for i in range(ns + 1):
        s.bp_pc_start[i] = s.bp_ct_start[i]
    s.pc_valid[None] = 1


@ti.func
def uf_find(s: ti.template(), x):
    r = x
    while s.body_island[r] != r:
        s.body_island[r] = s.body_island[s.body_island[r]]
        r = s.body_island[r]
    return r


@ti.kernel
def k_sleep(s: ti.template(), nb: ti.i32, nc: ti.i32, time_to_sleep: float):
    for b in range(nb):
        s.body_island[b] = b
        s.body_island_time[b] = BIG
    ti.loop_config(serialize=True)
    for c in range(nc):
        a = s.ct_body_a[c]
        b = s.ct_body_b[c]
        if b >= 0 and s.ct_lmax[c] > 0.0:
            if is_active(s, a) and is_active(s, b):
                ra = uf_find(s, a)
                rb = uf_find(s, b)
                if ra < rb:
                    s.body_island[rb] = ra
                elif rb < ra:
                    s.body_island[ra] = rb
    ti.loop_config(serialize=True)
    for b in range(nb):
        s.body_island[b] = uf_find(s, b)
    for b in range(nb):
        if is_active(s, b):
            ti.atomic_min(s.body_island_time[s.body_island[b]], s.body_sleep_time[b])
    for b in range(nb):
        if is_active(s, b) and s.body_island_time[s.body_island[b]] >= time_to_sleep:
            s.body_asleep[b] = 1
            s.body_v[b] = vec3(0.0)
            s.body_w[b] = vec3(0.0)


# --------------------------------------------------------------------------- host transfers
@ti.kernel
def k_upload_bodies(
    s: ti.template(),
    start: ti.i32,
    n: ti.i32,
    inv_mass: ti.types.ndarray(),
    ref_com: ti.types.ndarray(),
    inv_inertia: ti.types.ndarray(),
    principal_q: ti.types.ndarray(),
    inv_principal: ti.types.ndarray(),
    restitution: ti.types.ndarray(),
    friction: ti.types.ndarray(),
    static: ti.types.ndarray(),
    alive: ti.types.ndarray(),
    x: ti.types.ndarray(),
    q: ti.types.ndarray(),
    v: ti.types.ndarray(),
    w: ti.types.ndarray(),
    asleep: ti.types.ndarray(),
    sleep_time: ti.types.ndarray(),
):
    for u in range(n):
        b = start + u
        s.body_inv_mass[b] = inv_mass[u]
        s.body_ref_com[b] = vec3(ref_com[u, 0], ref_com[u, 1], ref_com[u, 2])
        for r, c in ti.static(ti.ndrange(3, 3)):
            s.body_inv_inertia[b][r, c] = inv_inertia[u, r, c]
        s.body_principal_q[b] = vec4(
            principal_q[u, 0], principal_q[u, 1], principal_q[u, 2], principal_q[u, 3]
        )
        s.body_inv_principal[b] = vec3(inv_principal[u, 0], inv_principal[u, 1], inv_principal[u, 2])
        s.body_restitution[b] = restitution[u]
        s.body_friction[b] = friction[u]
        s.body_static[b] = static[u]
        s.body_alive[b] = alive[u]
        s.body_x[b] = vec3(x[u, 0], x[u, 1], x[u, 2])
        s.body_q[b] = vec4(q[u, 0], q[u, 1], q[u, 2], q[u, 3])
        s.body_v[b] = vec3(v[u, 0], v[u, 1], v[u, 2])
        s.body_w[b] = vec3(w[u, 0], w[u, 1], w[u, 2])
        s.body_asleep[b] = asleep[u]
        s.body_sleep_time[b] = sleep_time[u]


@ti.kernel
def k_download_bodies(
    s: ti.template(),
    n: ti.i32,
    x: ti.types.ndarray(),
    q: ti.types.ndarray(),
    v: ti.types.ndarray(),
    w: ti.types.ndarray(),
    asleep: ti.types.ndarray(),
    sleep_time: ti.types.ndarray(),
    alive: ti.types.ndarray(),
):
    for b in range(n):
        for k in ti.static(range(3)):
            x[b, k] = s.body_x[b][k]
            v[b, k] = s.body_v[b][k]
            w[b, k] = s.body_w[b][k]
        for k in ti.static(range(4)):
            q[b, k] = s.body_q[b][k]
        asleep[b] = s.body_asleep[b]
        sleep_time[b] = s.body_sleep_time[b]
        alive[b] = s.body_alive[b]


@ti.kernel
def k_set_body_state(
    s: ti.template(),
    b: ti.i32,
    x: ti.types.ndarray(),
    q: ti.types.ndarray(),
    v: ti.types.ndarray(),
    w: ti.types.ndarray(),
    asleep: ti.i32,
    alive: ti.i32,
):
    s.body_x[b] = vec3(x[0], x[1], x[2])
    s.body_q[b] = vec4(q[0], q[1], q[2], q[3])
    s.body_v[b] = vec3(v[0], v[1], v[2])
    s.body_w[b] = vec3(w[0], w[1], w[2])
    s.body_asleep[b] = asleep
    s.body_alive[b] = alive
    s.body_sleep_time[b] = 0.0


@ti.kernel
def k_upload_spheres(
    s: ti.template(),
    start: ti.i32,
    n: ti.i32,
    local: ti.types.ndarray(),
    radius: ti.types.ndarray(),
    body: ti.types.ndarray(),
):
    for u in range(n):
        i = start + u
        s.bp_local[i] = vec3(local[u, 0], local[u, 1], local[u, 2])
        s.bp_radius[i] = radius[u]
        s.bp_body[i] = body[u]


@ti.kernel
def k_upload_colliders(
    s: ti.template(),
    start: ti.i32,
    n: ti.i32,
    kind: ti.types.ndarray(),
    x: ti.types.ndarray(),
    q: ti.types.ndarray(),
    nrm: ti.types.ndarray(),
    half: ti.types.ndarray(),
    restitution: ti.types.ndarray(),
    friction: ti.types.ndarray(),
):
    for u in range(n):
        k = start + u
        s.col_kind[k] = kind[u]
        s.col_x[k] = vec3(x[u, 0], x[u, 1], x[u, 2])
        s.col_q[k] = vec4(q[u, 0], q[u, 1], q[u, 2], q[u, 3])
        s.col_n[k] = vec3(nrm[u, 0], nrm[u, 1], nrm[u, 2])
        s.col_half[k] = vec3(half[u, 0], half[u, 1], half[u, 2])
        s.col_restitution[k] = restitution[u]
        s.col_friction[k] = friction[u]


@ti.kernel
def k_download_contacts(
    s: ti.template(),
    nc: ti.i32,
    a: ti.types.ndarray(),
    b: ti.types.ndarray(),
    ba: ti.types.ndarray(),
    bb: ti.types.ndarray(),
    p: ti.types.ndarray(),
    n: ti.types.ndarray(),
    ln: ti.types.ndarray(),
    vn0: ti.types.ndarray(),
    sep: ti.types.ndarray(),
):
    for c in range(nc):
        a[c] = s.ct_a[c]
        b[c] = s.ct_b[c]
        ba[c] = s.ct_body_a[c]
        bb[c] = s.ct_body_b[c]
        for k in ti.static(range(3)):
            p[c, k] = s.ct_p[c][k]
            n[c, k] = s.ct_n[c][k]
        ln[c] = s.ct_ltot[c]
        vn0[c] = s.ct_vn0[c]
        sep[c] = s.ct_sep[c]


@ti.kernel
def k_download_prev(
    s: ti.template(),
    nc: ti.i32,
    ns: ti.i32,
    pb: ti.types.ndarray(),
    pln: ti.types.ndarray(),
    plt: ti.types.ndarray(),
    pstart: ti.types.ndarray(),
):
    for c in range(nc):
        pb[c] = s.pc_b[c]
        pln[c] = s.pc_ln[c]
        for k in ti.static(range(3)):
            plt[c, k] = s.pc_lt[c][k]
    for i in range(ns + 1):
        pstart[i] = s.bp_pc_start[i]


@ti.kernel
def k_upload_prev(
    s: ti.template(),
    nc: ti.i32,
    ns: ti.i32,
    pb: ti.types.ndarray(),
    pln: ti.types.ndarray(),
    plt: ti.types.ndarray(),
    pstart: ti.types.ndarray(),
    valid: ti.i32,
):
    for c in range(nc):
        s.pc_b[c] = pb[c]
        s.pc_ln[c] = pln[c]
        s.pc_lt[c] = vec3(plt[c, 0], plt[c, 1], plt[c, 2])
    for i in range(ns + 1):
        s.bp_pc_start[i] = pstart[i]
    s.pc_valid[None] = valid


@ti.kernel
def k_wake(s: ti.template(), ids: ti.types.ndarray(), n: ti.i32):
    for u in range(n):
        b = ids[u]
        if s.body_alive[b] == 1 and s.body_static[b] == 0 and s.body_asleep[b] == 1:
            s.body_asleep[b] = 0
            s.body_sleep_time[b] = 0.0


@ti.kernel
def k_count_awake(s: ti.template(), nb: ti.i32) -> ti.i32:
    """Bodies that are alive, dynamic and awake."""
    n = 0
    for b in range(nb):
        if is_active(s, b):
            n += 1
    return n
