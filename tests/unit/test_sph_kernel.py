"""sph.kernel: Eq. 4 normalisation and gradient, Eq. 5 axes, Eq. 6 rotation convention, WPCA."""

import numpy as np
import pytest
import taichi as ti
from scipy.spatial.transform import Rotation

from sph.kernel import (
    K_R_DEFAULT,
    kernel_from_axes,
    kernel_grad,
    kernel_grad_np,
    kernel_isotropic,
    kernel_w,
    kernel_w_np,
    kernel_wpca,
    rotate_kernel_np,
    support_radius_np,
)


@ti.kernel
def _integrate(G: ti.math.mat3, ext: ti.math.vec3, n: ti.i32) -> float:
    """Midpoint rule of W(r, G) over the world-axis box [-ext, ext] with n^3 cells."""
    s = 0.0
    cell = 2.0 * ext / n
    for i, j, k in ti.ndrange(n, n, n):
        r = -ext + (ti.Vector([i, j, k]) + 0.5) * cell
        s += kernel_w(r, G)
    return s * cell[0] * cell[1] * cell[2]


@ti.kernel
def _eval(
    r: ti.types.ndarray(dtype=ti.math.vec3, ndim=1),
    G: ti.types.ndarray(dtype=ti.math.mat3, ndim=1),
    w: ti.types.ndarray(ndim=1),
    g: ti.types.ndarray(dtype=ti.math.vec3, ndim=1),
):
    for i in r:
        w[i] = kernel_w(r[i], G[i])
        g[i] = kernel_grad(r[i], G[i])


def _eval_ti(r: np.ndarray, G: np.ndarray):
    w = np.zeros(len(r))
    g = np.zeros_like(r)
    _eval(np.ascontiguousarray(r), np.ascontiguousarray(G), w, g)
    return w, g


def _random_G(ratio: float, seed: int) -> np.ndarray:
    R = Rotation.random(random_state=seed).as_matrix()
    h = 0.3 * np.array([1.0, np.sqrt(ratio), ratio]) / ratio  # longest/shortest = ratio
    return kernel_from_axes(R, h)


@pytest.mark.parametrize("ratio", [1.0, 4.0, 10.0])
@pytest.mark.parametrize("seed", [1, 2])
def test_kernel_integrates_to_one(ratio, seed, taichi_runtime):
    G = _random_G(ratio, seed)
    Gi = np.linalg.inv(G)
    ext = np.sqrt(np.diag(Gi @ Gi.T)) * 1.0001  # box around the support ellipsoid
    total = _integrate(ti.Matrix(G.tolist()), ti.Vector(ext.tolist()), 200)
    assert total == pytest.approx(1.0, abs=1e-6)  # midpoint-rule error here is ~5e-8


@pytest.mark.parametrize("ratio", [1.0, 4.0, 10.0])
def test_gradient_matches_finite_differences(ratio, taichi_runtime):
    rng = np.random.default_rng(int(ratio))
    G = _random_G(ratio, int(ratio) + 10)
    n = 300
    # points inside the support at |G r| in [0.05, 0.95]
    dirs = rng.standard_normal((n, 3))
    s = dirs / np.linalg.norm(dirs, axis=1, keepdims=True) * rng.uniform(0.05, 0.95, (n, 1))
    r = s @ np.linalg.inv(G).T
    Gs = np.broadcast_to(G, (n, 3, 3)).copy()
    w, g = _eval_ti(r, Gs)
    np.testing.assert_allclose(w, kernel_w_np(r, G), rtol=1e-13)
    np.testing.assert_allclose(g, kernel_grad_np(r, G), rtol=1e-12, atol=1e-12 * np.abs(g).max())
    step = 1e-6 / np.linalg.eigvalsh(G)[-1]
    fd = np.zeros_like(r)
    for a in range(3):
        e = np.zeros(3)
        e[a] = step
        wp, _ = _eval_ti(r + e, Gs)
        wm, _ = _eval_ti(r - e, Gs)
        fd[:, a] = (wp - wm) / (2 * step)
    err = np.linalg.norm(fd - g, axis=1) / np.linalg.norm(g, axis=1)
    assert err.max() < 1e-6


def test_outside_support_and_origin(taichi_runtime):
    G = _random_G(4.0, 3)
    r = np.array([[0.0, 0.0, 0.0], np.linalg.solve(G, [1.0, 0.0, 0.0]) * 1.0000001])
    w, g = _eval_ti(r, np.broadcast_to(G, (2, 3, 3)).copy())
    assert w[0] == pytest.approx(15 / np.pi * np.linalg.det(G))
    assert np.all(g[0] == 0.0)  # gradient defined as 0 at r = 0
    assert w[1] == 0.0 and np.all(g[1] == 0.0)


def test_axes_and_isotropic_case():
    R = Rotation.from_euler("zyx", [30, 20, 10], degrees=True).as_matrix()
    G = kernel_from_axes(R, [0.1, 0.2, 0.4])
    for k, h in enumerate([0.1, 0.2, 0.4]):
        assert np.linalg.norm(G @ (h * R[:, k])) == pytest.approx(1.0)  # semi-axis h_k along axis k
    assert support_radius_np(G) == pytest.approx(0.4)
    np.testing.assert_allclose(kernel_isotropic(0.5), np.eye(3) * 2.0)


def test_rotation_convention_eq6():
    """With x_cur = M x_rest, G_t = M G0 M^T gives the same kernel value as G0 on rest vectors."""
    rng = np.random.default_rng(4)
    G0 = _random_G(4.0, 5)
    M = Rotation.random(random_state=6).as_matrix()
    Gt = rotate_kernel_np(G0, M)
    r_rest = rng.uniform(-0.1, 0.1, (50, 3))
    r_cur = r_rest @ M.T
    np.testing.assert_allclose(kernel_w_np(r_cur, Gt), kernel_w_np(r_rest, G0), rtol=1e-12, atol=1e-12)
    # the paper's form M^T G0 M is the same update written with the inverse rotation
    np.testing.assert_allclose(rotate_kernel_np(G0, M.T), M.T @ G0 @ M, atol=1e-15)


def test_wpca_on_a_plate():
    """WPCA on a flat sheet: the kernel shrinks across the sheet, det(G) matches I/h, ratio <= k_r."""
    d = 0.01
    g = np.arange(-10, 11) * d
    X, Y = np.meshgrid(g, g, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)  # one layer: flat in z
    R = Rotation.from_euler("xz", [35, 20], degrees=True).as_matrix()
    x = x @ R.T
    h = 3.0 * d
    G = kernel_wpca(x, h)
    centre = np.argmin(np.linalg.norm(x - x.mean(0), axis=1))
    w, V = np.linalg.eigh(G[centre])
    lengths = 1.0 / w  # ascending eigenvalues of G: longest axis first
    assert lengths[0] / lengths[-1] == pytest.approx(K_R_DEFAULT, rel=1e-6)  # clamped at k_r
    assert np.prod(lengths) == pytest.approx(h**3, rel=1e-9)  # same kernel volume as I/h
    normal = R @ [0, 0, 1]
    assert abs(V[:, -1] @ normal) == pytest.approx(1.0, abs=1e-6)  # shortest axis = plate normal
    # scene scaling: x3 along the surface, x1/5 across
    Gs = kernel_wpca(x, h, axis_scale=(3.0, 3.0, 0.2))
    ws = np.linalg.eigvalsh(Gs[centre])
    np.testing.assert_allclose(np.sort(1.0 / ws), np.sort(lengths * [3.0, 3.0, 0.2]), rtol=1e-9)
    # an isolated particle keeps the isotropic kernel
    G1 = kernel_wpca(np.array([[0.0, 0.0, 0.0], [5.0, 5.0, 5.0]]), h)
    np.testing.assert_allclose(G1, np.broadcast_to(np.eye(3) / h, (2, 3, 3)))


def test_wpca_matches_a_per_particle_reference():
    """The vectorised WPCA equals the module doc's recipe done one particle at a time with the Jacobi
    eigen solver (sph.eigen.sym_eig3_np, not LAPACK): weighted covariance, axes sorted major to minor,
    the k_r clamp, det(G) = h^-3, axis_scale on the sorted axes, I/h for a particle with too few
    neighbours. A slab with jitter makes the minor axes clamp; two far points stay isotropic."""
    from sph.eigen import sym_eig3_np

    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform([0, 0, 0], [0.1, 0.1, 0.006], (400, 3)), [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]])
    h, k_r, scale = 0.02, 3.0, np.array([2.0, 1.5, 0.5])
    G = kernel_wpca(x, h, k_r=k_r, axis_scale=scale)
    clamped = 0
    for i in range(len(x)):
        d = np.linalg.norm(x - x[i], axis=1)
        near = d <= h
        if near.sum() < 6:
            np.testing.assert_allclose(G[i], np.eye(3) / h, rtol=1e-12)
            continue
        w = 1.0 - (d[near] / h) ** 3
        m = (w[:, None] * x[near]).sum(0) / w.sum()
        dx = x[near] - m
        vals, R = sym_eig3_np((w[:, None, None] * dx[:, :, None] * dx[:, None, :]).sum(0) / w.sum())
        s = np.sqrt(np.maximum(vals, vals[0] / k_r**2))
        clamped += int(vals[2] < vals[0] / k_r**2)
        lengths = h * s / np.cbrt(np.prod(s))
        np.testing.assert_allclose(G[i], R @ np.diag(1.0 / (lengths * scale)) @ R.T, rtol=1e-9, atol=1e-9 / h)
    assert clamped > 50  # the clamp was exercised
