"""Principal values and directions of symmetric 3x3 tensors (cyclic Jacobi).

Used for principal stresses (Rankine criterion, Sect. 4.2), kernel axes (Eq. 5) and WPCA.
`ti.sym_eig` is wrong in Taichi 1.7.4 (issue 8468: diagonal/block-diagonal input and repeated
eigenvalues), so this module is the project's replacement.

Method: subtract the isotropic part m = tr(A)/3 (it does not change the eigenvectors and keeps
the off-diagonal-to-diagonal ratio meaningful for nearly isotropic stresses), scale by the
largest entry, then cyclic Jacobi sweeps over the pairs (0,1), (0,2), (1,2) with the stable
rotation of Numerical Recipes 11.1: theta = (a_qq - a_pp) / (2 a_pq),
t = sgn(theta) / (|theta| + sqrt(theta^2 + 1)), c = 1/sqrt(t^2+1), s = t c. Convergence is
quadratic; sweeps stop when the off-diagonal sum of squares is below (eps^2/100) of the scaled
matrix (at most MAX_SWEEPS = 12; 4 to 6 are used in f64). Eigenvalues are sorted descending,
eigenvectors are the columns of V, orthonormal and right-handed (det V = +1).

`sym_eig3` is the Taichi function; `sym_eig3_np` is the numpy twin (same algorithm, float64);
`sym_eig3_batch` runs the Taichi function on a numpy batch (tests, host-side use).
"""


import numpy as np
import taichi as ti

from core.runtime import float_eps, numpy_float

MAX_SWEEPS = 12  # cyclic sweeps at most; quadratic convergence needs 4-6 in f64


@ti.func
def _jacobi_rotate(B, V, p: ti.template(), q: ti.template()):
    """One Jacobi rotation zeroing B[p, q] (p < q static); returns (B', V')."""
    apq = B[p, q]
    if apq != 0.0:
        theta = (B[q, q] - B[p, p]) / (2.0 * apq)
        t = 1.0 / (ti.abs(theta) + ti.sqrt(theta * theta + 1.0))
        if theta < 0.0:
            t = -t
        c = 1.0 / ti.sqrt(t * t + 1.0)
        s = t * c
        J = ti.Matrix.identity(float, 3)
        J[p, p] = c
        J[q, q] = c
        J[p, q] = s
        J[q, p] = -s
        B = J.transpose() @ B @ J
        B[p, q] = 0.0  # exact by construction; removes round-off
        B[q, p] = 0.0
        V = V @ J
    return B, V


@ti.func
def _swap_if_less(vals, V, a: ti.template(), b: ti.template()):
    """Order columns a < b so that vals[a] >= vals[b] (a, b static)."""
    if vals[a] < vals[b]:
        tmp = vals[a]
        vals[a] = vals[b]
        vals[b] = tmp
        for r in ti.static(range(3)):
            tv = V[r, a]
            V[r, a] = V[r, b]
            V[r, b] = tv
    return vals, V


@ti.func
def sym_eig3(A):
    """Eigen-decomposition of a symmetric 3x3 matrix A (only its symmetric part is read).

    Returns (values: vec3, descending; V: mat3 whose columns are orthonormal eigenvectors, det +1).
    """
    S = 0.5 * (A + A.transpose())
    m = (S[0, 0] + S[1, 1] + S[2, 2]) / 3.0
    B = S - m * ti.Matrix.identity(float, 3)
    scale = 0.0
    for r in ti.static(range(3)):
        for c in ti.static(range(3)):
            scale = ti.max(scale, ti.abs(B[r, c]))
    V = ti.Matrix.identity(float, 3)
    if scale > 0.0:
        B = B / scale
        tol = ti.static(float_eps() ** 2 * 1e-2)
        for _ in range(MAX_SWEEPS):
            off = B[0, 1] ** 2 + B[0, 2] ** 2 + B[1, 2] ** 2
            if off <= tol:
                break
            B, V = _jacobi_rotate(B, V, 0, 1)
            B, V = _jacobi_rotate(B, V, 0, 2)
            B, V = _jacobi_rotate(B, V, 1, 2)
        B = B * scale
    vals = ti.Vector([B[0, 0] + m, B[1, 1] + m, B[2, 2] + m])
    vals, V = _swap_if_less(vals, V, 0, 1)
    vals, V = _swap_if_less(vals, V, 1, 2)
    vals, V = _swap_if_less(vals, V, 0, 1)
    if V.determinant() < 0.0:
        for r in ti.static(range(3)):
            V[r, 2] = -V[r, 2]
    return vals, V


# ----------------------------------------------------------------------------- numpy twin


def _sym_eig3_one(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    S = 0.5 * (A + A.T)
    m = np.trace(S) / 3.0
    B = S - m * np.eye(3)
    scale = np.abs(B).max()
    V = np.eye(3)
    if scale > 0.0:
        B = B / scale
        tol = np.finfo(np.float64).eps ** 2 * 1e-2
        for _ in range(MAX_SWEEPS):
            if B[0, 1] ** 2 + B[0, 2] ** 2 + B[1, 2] ** 2 <= tol:
                break
            for p, q in ((0, 1), (0, 2), (1, 2)):
                apq = B[p, q]
                if apq == 0.0:
                    continue
                theta = (B[q, q] - B[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                J = np.eye(3)
                J[p, p] = J[q, q] = c
                J[p, q] = s
                J[q, p] = -s
                B = J.T @ B @ J
                B[p, q] = B[q, p] = 0.0
                V = V @ J
        B = B * scale
    vals = np.diag(B) + m
    order = np.argsort(-vals, kind="stable")
    vals = vals[order]
    V = V[:, order]
    if np.linalg.det(V) < 0.0:
        V[:, 2] = -V[:, 2]
    return vals, V


def sym_eig3_np(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """numpy twin of `sym_eig3` for (3,3) or (n,3,3) input: (values desc, column eigenvectors)."""
    A = np.asarray(A, dtype=np.float64)
    if A.shape == (3, 3):
        return _sym_eig3_one(A)
    vals = np.empty(A.shape[:-1])
    vecs = np.empty_like(A)
    for k in range(A.shape[0]):
        vals[k], vecs[k] = _sym_eig3_one(A[k])
    return vals, vecs


@ti.kernel
def _eig_batch_kernel(
    A: ti.types.ndarray(dtype=ti.math.mat3, ndim=1),
    vals: ti.types.ndarray(dtype=ti.math.vec3, ndim=1),
    vecs: ti.types.ndarray(dtype=ti.math.mat3, ndim=1),
):
    for i in A:
        w, V = sym_eig3(A[i])
        vals[i] = w
        vecs[i] = V


def sym_eig3_batch(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run the Taichi `sym_eig3` on an (n,3,3) numpy batch; returns (n,3) values and (n,3,3) vectors."""
    dtype = numpy_float()
    A = np.ascontiguousarray(np.asarray(A, dtype=dtype).reshape(-1, 3, 3))
    vals = np.zeros((A.shape[0], 3), dtype=dtype)
    vecs = np.zeros_like(A)
    if A.shape[0]:
        _eig_batch_kernel(A, vals, vecs)
    return vals, vecs
