"""Rigid step, stages 3-5 (rigid/step.py): the narrow phase (contacts per sphere, then each sphere's
partner keys in its CSR segment, sorted, so contacts are ordered by (sphere a, key b) whatever the
grid did) and the contact set-up (sphere-sphere, sphere-plane and sphere-box geometry, effective
masses, the pre-solve normal speed, warm-start impulses matched by (a, b) key)."""

import taichi as ti

from rigid.broad_phase import cell_hash
from rigid.kernel_math import (
    BIG,
    is_active,
    ivec3,
    mat3,
    q_to_mat,
    tangents,
    vec3,
)


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
    hmask = s.grid_mask[None]
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
    own_end = s.body_sphere_end[bi]
    lo_i, hi_i = s.bp_cell_lo[i], s.bp_cell_hi[i]
    for cz in range(lo_i[2], hi_i[2] + 1):
        for cy in range(lo_i[1], hi_i[1] + 1):
            for cx in range(lo_i[0], hi_i[0] + 1):
                h = cell_hash(ivec3(cx, cy, cz), hmask)
                if s.grid_top[h] < own_end:
                    continue  # the walk below would stop at its first entry
                # a bucket lists its spheres in increasing id (fill_grid's serial scatter) and i's body holds
                # the ids i+1..end-1 after it (fill_grid): walk the bucket from the top and stop at the
                # first j < end, past every partner j > i of another body and none of i's own
                first, last = s.grid_start[h], s.grid_start[h + 1]
                prev = -1
                for t in range(last - first):
                    j = s.grid_entry[last - 1 - t]
                    if j < own_end:
                        break
                    if j == prev:
                        continue  # two of j's cells share this bucket: its entries stand side by side
                    prev = j
                    # the pair cannot touch when the centres are farther apart than both reaches and the
                    # margin: read from the bucket's own copy, in sequence (most candidates stop here)
                    xr = s.grid_reach[last - 1 - t]
                    far = (ri + swi + margin + xr[3]) * (1.0 + 1e-5)
                    if (xi - xr.xyz).norm_sqr() > far * far:
                        continue
                    # a pair is met in one cell only, the lowest both boxes cover (broad_phase.box_cells);
                    # this also drops a j listed here for another cell with the same hash
                    lo_j, hi_j = s.bp_cell_lo[j], s.bp_cell_hi[j]
                    if (ti.max(lo_i[0], lo_j[0]) != cx or ti.max(lo_i[1], lo_j[1]) != cy
                            or ti.max(lo_i[2], lo_j[2]) != cz or cx > hi_j[0] or cy > hi_j[1] or cz > hi_j[2]):
                        continue
                    bj = s.bp_body[j]
                    aj = s.body_active[bj]
                    if ai == 1 or aj == 1:
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


@ti.func
def gather(s: ti.template(), ns: ti.i32, ncol: ti.i32, margin: float):
    for i in range(ns):
        base = s.bp_ct_start[i]
        cnt = 0
        if s.bp_ct_start[i + 1] > base:  # the count pass found none: nothing to write
            cnt = scan_sphere(s, i, ncol, margin, True)
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


@ti.func
def contact_geometry(s: ti.template(), i, key, ba):
    """Sphere i of body ba against sphere `key` (>= 0) or collider -1 - key: the other body (-1 for a
    collider), unit normal from B towards A, signed gap (m), contact point midway between the
    surfaces, and the pair's friction and restitution."""
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
    return bb, n, gap, p, mu, e


@ti.func
def set_up(s: ti.template(), nc: ti.i32, use_warm: ti.i32, warm_factor: float, warm_depth: float):
    for c in range(nc):
        i = s.ct_a[c]
        key = s.ct_b[c]
        ba = s.bp_body[i]
        bb, n, gap, p, mu, e = contact_geometry(s, i, key, ba)
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
        if use_warm == 1 and s.pc_valid[None] == 1 and gap >= -warm_depth:  # a deep overlap starts from zero
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
