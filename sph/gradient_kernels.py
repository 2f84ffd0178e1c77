"""The SPH gradient of Algorithm 1 (paper Eq. 4, 7, 10) as Taichi kernels: the neighbour test over
each member's anisotropic support and, per member, the sums of the corrections and of the gradient,
one member per loop iteration (sph/gradient.py decides when they run and inverts the corrections
between the two sums with numpy, so the quadratic fit's rank cut is numpy's pseudo-inverse).

The analysis is float64 whatever the run's precision (sph/cracks.py), so every array and local here
is float64: locals are declared float64 and the only literals (0 and 1) are exact in either precision.
Host numpy spent about 0.5 us a pair on temporaries (Pots: 21k pairs, 18 ms of each 35 ms analysis);
these loops do the same arithmetic without them. They run on the CPU backend only: Taichi 1.7.4's
CUDA backend fails on float64 local matrices (docs/decisions.md, "CUDA and f64").
No `from __future__ import annotations` here: Taichi reads the kernels' annotations as objects.
"""

import numpy as np
import taichi as ti

nd_f64_1 = ti.types.ndarray(dtype=ti.f64, ndim=1)
nd_f64_2 = ti.types.ndarray(dtype=ti.f64, ndim=2)
nd_f64_3 = ti.types.ndarray(dtype=ti.f64, ndim=3)
nd_i32_1 = ti.types.ndarray(dtype=ti.i32, ndim=1)
vec3_64 = ti.types.vector(3, ti.f64)
vec9_64 = ti.types.vector(9, ti.f64)
mat3_64 = ti.types.matrix(3, 3, ti.f64)
mat99_64 = ti.types.matrix(9, 9, ti.f64)


@ti.func
def _vec3(a: ti.template(), r):
    return vec3_64(a[r, 0], a[r, 1], a[r, 2])


@ti.func
def _mat3(a: ti.template(), r):
    return mat3_64([[a[r, 0, 0], a[r, 0, 1], a[r, 0, 2]], [a[r, 1, 0], a[r, 1, 1], a[r, 1, 2]],
                    [a[r, 2, 0], a[r, 2, 1], a[r, 2, 2]]])


@ti.func
def _quad_basis(X):
    """Linear and quadratic monomials of a scaled offset (sph/gradient.py `_quad_basis`)."""
    return vec9_64(X[0], X[1], X[2], X[0] * X[0], X[1] * X[1], X[2] * X[2], X[0] * X[1], X[0] * X[2], X[1] * X[2])


@ti.func
def _kernel_factor(Gx, coef):
    """k_ij of Eq. 4's gradient, grad W = k G^2 (x_j - x_i), from Gx = G (x_j - x_i); 0 outside the support."""
    q = Gx.norm()
    k = ti.f64(0.0)
    if q > 0.0 and q < 1.0:
        k = coef * (1.0 - q) * (1.0 - q) / q
    return k


@ti.kernel
def k_pair_list(xm: nd_f64_2, Gm: nd_f64_3, im: nd_i32_1, xl: nd_f64_2, il: nd_i32_1, owner: nd_i32_1,
                nbr: nd_i32_1, count: nd_i32_1):
    """The pairs (e, l) where local particle l lies in member e's support, |G_e (x_l - x_e)| < 1, and is not
    e, listed in (e, l) order into owner and nbr (room for every (e, l) at most); count[0]: how many.
    One serial task (the list's order is the loops'); the member's tensor and centre are read once for
    its row. Listing the pairs here saves the (e, l) mask and numpy's pass over it (0.7 ms an analysis
    in Pots, whose neighbour tests pass over 130 x 520 (e, l) on average)."""
    for _ in range(1):
        n = 0
        for e in range(xm.shape[0]):
            G = _mat3(Gm, e)
            x_e = _vec3(xm, e)
            own = im[e]
            for l in range(xl.shape[0]):
                g = G @ (_vec3(xl, l) - x_e)
                if g.dot(g) < 1.0 and il[l] != own:
                    owner[n] = e
                    nbr[n] = l
                    n += 1
        count[0] = n


@ti.kernel
def k_fit_moments(x: nd_f64_2, vol: nd_f64_1, members: nd_i32_1, Gm: nd_f64_3, coef: nd_f64_1, srad: nd_f64_1,
                  start: nd_i32_1, nbr: nd_i32_1, quad: nd_i32_1, moments: nd_f64_3):
    """Per member where quad[e]: the quadratic fit's moment matrix sum_j w_j b_j b_j^T (w = V_j k_ij, b the
    monomials of (x_j - x_i) / support radius). x (N,3) m, vol (N,) m^3; per member e of M: members (M,)
    rows of x, Gm (M,3,3) 1/m, coef (M,) = Eq. 4's gradient constant x det G, srad (M,) m support
    radius, quad (M,) 1 where fitted; its pairs nbr[start[e]:start[e+1]] (rows of x). Writes moments
    (M,9,9) of those members. (The Bonet-Lok sums are a kernel of their own: each loads in under 0.1 s,
    a warm-up piece that fits in a wait for a drawn frame.)"""
    for e in range(members.shape[0]):
        if quad[e] != 0:
            i = members[e]
            G = _mat3(Gm, e)
            acc = mat99_64(0.0)
            for p in range(start[e], start[e + 1]):
                j = nbr[p]
                xi = _vec3(x, j) - _vec3(x, i)
                b = _quad_basis(xi / srad[e])
                w = vol[j] * _kernel_factor(G @ xi, coef[e])
                for a in range(9):  # the upper triangle, in runtime loops: unrolled, the kernel took 0.24 s to load
                    wa = w * b[a]
                    for c in range(a, 9):
                        acc[a, c] += wa * b[c]
            for a in range(9):
                for c in range(9):
                    moments[e, a, c] = acc[ti.min(a, c), ti.max(a, c)]


@ti.kernel
def k_bonet_lok_sums(x: nd_f64_2, vol: nd_f64_1, members: nd_i32_1, Gm: nd_f64_3, coef: nd_f64_1,
                     start: nd_i32_1, nbr: nd_i32_1, quad: nd_i32_1, B: nd_f64_3):
    """Per member where not quad[e]: the Bonet-Lok matrix sum_j V_j grad W (x) (x_j - x_i), written to B
    (M,3,3); the other arguments as `k_fit_moments`."""
    for e in range(members.shape[0]):
        if quad[e] == 0:
            i = members[e]
            G = _mat3(Gm, e)
            acc = mat3_64(0.0)
            for p in range(start[e], start[e + 1]):
                j = nbr[p]
                xi = _vec3(x, j) - _vec3(x, i)
                Gx = G @ xi
                acc += (vol[j] * _kernel_factor(Gx, coef[e]) * (G @ Gx)).outer_product(xi)
            for a, c in ti.static(ti.ndrange(3, 3)):
                B[e, a, c] = acc[a, c]


@ti.kernel
def k_gradient_sums(x: nd_f64_2, vol: nd_f64_1, u: nd_f64_2, members: nd_i32_1, Gm: nd_f64_3, coef: nd_f64_1,
                    srad: nd_f64_1, start: nd_i32_1, nbr: nd_i32_1, quad: nd_i32_1, Minv: nd_f64_3,
                    L: nd_f64_3, grad: nd_f64_3):
    """Eq. 7 per member: grad u_i = sum_j (u_j - u_i) (x) d_ij, with d_ij the quadratic fit's linear terms
    (Minv: the first 3 columns of the moment matrix's pseudo-inverse) where quad[e], else L V_j grad W
    (L: Bonet-Lok's inverse, or I for the plain weights). u (N,3) m/N; Minv (M,9,3), L (M,3,3); the other
    arguments as `k_fit_moments`. Writes grad (M,3,3)."""
    for e in range(members.shape[0]):
        i = members[e]
        G = _mat3(Gm, e)
        Le = _mat3(L, e)
        acc = mat3_64(0.0)
        for p in range(start[e], start[e + 1]):
            j = nbr[p]
            xi = _vec3(x, j) - _vec3(x, i)
            Gx = G @ xi
            k = _kernel_factor(Gx, coef[e])
            d = vec3_64(0.0)
            if quad[e] != 0:
                b = _quad_basis(xi / srad[e])
                for a in range(9):
                    for c in ti.static(range(3)):
                        d[c] += b[a] * Minv[e, a, c]
                d *= vol[j] * k / srad[e]
            else:
                d = Le @ (vol[j] * k * (G @ Gx))
            acc += (_vec3(u, j) - _vec3(u, i)).outer_product(d)
        for a, c in ti.static(ti.ndrange(3, 3)):
            grad[e, a, c] = acc[a, c]


def f64(a) -> np.ndarray:
    """A C-contiguous float64 copy of `a` only where it is not one already (the kernels' argument layout)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def i32(a) -> np.ndarray:
    """Indices as the kernels take them (Taichi's loop bounds are 32-bit)."""
    return np.ascontiguousarray(a, dtype=np.int32)


def warm_pieces() -> list:
    """Launchers of the four kernels on nothing, one piece each (each loads in 30-90 ms), so that they
    compile (sim/warm_up.py) before the first analysis needs them."""
    f1, f2, f3, n, s1 = np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0, np.int32), np.zeros(1, np.int32)
    return [lambda: k_pair_list(f2, f3, n, f2, n, n, n, s1),
            lambda: k_fit_moments(f2, f1, n, f3, f1, f1, s1, n, n, np.zeros((0, 9, 9))),
            lambda: k_bonet_lok_sums(f2, f1, n, f3, f1, s1, n, n, f3),
            lambda: k_gradient_sums(f2, f1, f2, n, f3, f1, f1, s1, n, n, np.zeros((0, 9, 3)), f3, f3)]
