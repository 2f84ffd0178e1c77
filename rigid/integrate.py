"""Rigid step, position integration (rigid/step.py, inside each substep): x += h v, and the rotation by
the Dullweber-Leimkuhler-McLachlan (1997) splitting in the principal frame (exact sub-rotations about
the principal axes in the Strang order 1-2-3-2-1), which keeps the world angular momentum exactly and
has no energy drift."""

import taichi as ti

from rigid.kernel_math import (
    q_conj,
    q_mul,
    q_normalized,
    q_to_mat,
    vec3,
    vec4,
)


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
