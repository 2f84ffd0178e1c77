"""Rigid step, stages 6-9 (rigid/step.py): support levels and mass scaling of heavy-on-light contacts,
the substeps (symplectic Euler over h = dt / m: forces, warm start, sequential impulses with a Coulomb
cone and a speculative non-penetration allowance, integration), split-impulse position correction
on pseudo velocities, and restitution with the sleep timers."""

import taichi as ti

from rigid.integrate import integrate_body
from rigid.kernel_math import (
    is_active,
    q_exp,
    q_mul,
    q_normalized,
    q_to_mat,
    vec3,
)
from rigid.narrow_phase import eff_mass, point_velocity


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
def carries_impulse(s: ti.template(), c):
    """Contact c holds a normal or a friction impulse (this substep's, or the warm start's)."""
    return s.ct_ln[c] != 0.0 or s.ct_lt1[c] != 0.0 or s.ct_lt2[c] != 0.0


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


@ti.func
def support_levels(s: ti.template(), nb: ti.i32, nc: ti.i32, max_levels: ti.i32):
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
    # Most contacts carry no impulse (the speculative ones, and the crack faces of a split's co-moving
    # pieces, thousands of sphere pairs a piece): where an impulse is zero, applying it would only add
    # zeros, so it is skipped, and so is the friction of a contact without normal or friction impulse
    # (its cone is the point 0). The same physics: what is skipped adds only zeros (LLVM's fast math
    # compiles the friction block inside its branch otherwise, so the last bits differ from before).
    ti.loop_config(serialize=True)
    for c in range(nc):
        if carries_impulse(s, c):
            apply_impulse(s, c, s.ct_ln[c] * s.ct_n[c] + s.ct_lt1[c] * s.ct_t1[c] + s.ct_lt2[c] * s.ct_t2[c])
    # velocity iterations: friction (cone clamp on the 2D tangent impulse), then the normal
    ti.loop_config(serialize=True)
    for it in range(vel_iters):
        for cc in range(nc):
            # symmetric Gauss-Seidel: alternate the sweep direction so that no contact order is favoured
            c = cc if (it + parity) % 2 == 0 else nc - 1 - cc
            n = s.ct_n[c]
            if carries_impulse(s, c):
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
            if ln != s.ct_ln[c]:
                apply_impulse(s, c, (ln - s.ct_ln[c]) * n)
                s.ct_ln[c] = ln
                s.ct_lmax[c] = ti.max(s.ct_lmax[c], ln)
    for c in range(nc):
        s.ct_ltot[c] += s.ct_ln[c]
    for b in range(nb):
        if is_active(s, b):
            integrate_body(s, b, h)


@ti.func
def correct_positions(
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
            if lp != s.ct_lp[c]:  # most contacts push nothing (k_substep's note)
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


@ti.func
def restitute(
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
            count_slow_time(s, b, dt, sleep_lin, sleep_ang)


@ti.func
def count_slow_time(s: ti.template(), b, dt, sleep_lin, sleep_ang):
    """Body b's sleep timer: how long it has been slower than the sleep speeds."""
    if s.body_v[b].norm() < sleep_lin and s.body_w[b].norm() < sleep_ang:
        s.body_sleep_time[b] += dt
    else:
        s.body_sleep_time[b] = 0.0
