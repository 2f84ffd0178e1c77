"""Taichi helpers shared by the rigid step's kernels: quaternions (w-x-y-z), body predicates, contact
tangent frames, and the vector types. Body b maps a reference point X to `R(q_b) (X - ref_com_b) + x_b`."""

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
