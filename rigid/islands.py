"""Rigid step, stages 10-11 (rigid/step.py): contacts saved for the next step's warm start, and
sleeping: islands of touching awake bodies (serial union-find); an island whose every body has been
slow for `time_to_sleep` goes to sleep."""

import taichi as ti

from rigid.kernel_math import (
    BIG,
    is_active,
    vec3,
)


# --------------------------------------------------------------------------- 9-10. bookkeeping
@ti.func
def save_contacts(s: ti.template(), nc: ti.i32, ns: ti.i32):
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


@ti.func
def sleep_islands(s: ti.template(), nb: ti.i32, nc: ti.i32, time_to_sleep: float):
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
            fall_asleep(s, b)


@ti.func
def fall_asleep(s: ti.template(), b):
    s.body_asleep[b] = 1
    s.body_v[b] = vec3(0.0)
    s.body_w[b] = vec3(0.0)
