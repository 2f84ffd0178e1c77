"""Host <-> Taichi transfers of the rigid store (rigid/store.py): bodies, spheres, colliders, contacts
and the warm-start store, uploaded or downloaded in one kernel each; waking bodies. They run where the
store's memory is not the host's (CUDA); on the CPU rigid/host_sync.py makes the same copies with
numpy on views of the fields (rigid/host_views.py), and tests/unit/test_rigid_host_views.py steps a
world both ways to the same bits."""

import taichi as ti

from rigid.kernel_math import (
    vec3,
    vec4,
)


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
