"""Anisotropic SPH kernel (Sect. 4.1, Eq. 4-6) and kernel tensors from axes or WPCA.

Eq. 4:  W(r, G)      = 15/pi * det(G) * (1 - |G r|)^3            for |G r| < 1, else 0
        grad W(r, G) = -45/pi * det(G) * G^2 r (1 - |G r|)^2 / |G r|  (G symmetric)
Normalisation: with s = G r, d^3r = d^3s / det(G), so the integral is
15/pi * 4 pi * int_0^1 (1-q)^3 q^2 dq = 60 / 60 = 1 for every symmetric positive definite G.
The gradient at r = 0 is set to 0 (the limit does not exist; the self term never matters because
every sum uses differences x_j - x_i).

Eq. 5:  G = R Gk R^T with the columns of R the kernel axes and Gk = diag(1/h_k); the support is
the ellipsoid |G r| < 1 with semi-axes h_k. `support_radius(G) = 1 / lambda_min(G)` = largest h_k.

Eq. 6 (rotation convention). Here M maps rest directions to current ones (x_cur = M x_rest, the
M_i of Eq. 3). A current-frame tensor must give |G_t r_cur| = |G_0 r_rest| = |G_0 M^T r_cur|,
and since M preserves lengths |G_0 M^T r| = |M G_0 M^T r|, so we implement G_t = M G_0 M^T.
The paper's Eq. 6 (G_t = M^T G_0 M) is the same update written with M mapping current to rest
directions (its M is our M^T).

WPCA (Yu & Turk 2013, as the paper's Sect. 4.1 asks): for particle i, neighbours j within the
isotropic radius h get weight w_ij = 1 - (|x_j - x_i| / h)^3; weighted mean m_i and weighted
covariance C_i = sum w (x_j - m_i)(x_j - m_i)^T / sum w; C_i = R diag(s_1 >= s_2 >= s_3) R^T.
Axis lengths follow the standard deviations sqrt(s_k) (Yu & Turk use s_k itself; the square root
makes the clamp a ratio of lengths), clamped so that no axis is shorter than 1/k_r of the longest
(k_r = 4 by default, as Yu & Turk), then rescaled so that h_1 h_2 h_3 = h^3: det(G) and hence the
kernel's support volume equal the isotropic kernel's. Finally the scene's per-axis factors
`axis_scale = (major, middle, minor)` multiply the lengths (the minor axis is the local surface
normal on a flat surface: the paper's "x1/5 across, x3 along the surface" is
axis_scale=(3, 3, 1/5)). Particles with fewer than `min_neighbours` neighbours keep G = I/h.
"""


import math

import numpy as np
import taichi as ti

from sph.eigen import sym_eig3

# the WPCA's version in its cache keys: raise it when `_wpca` gives other tensors for the same input, so that
# tensors cached by the old code are not read
WPCA_VERSION = 1
KERNEL_NORM = 15.0 / math.pi  # W normalisation of Eq. 4 (times det G)
GRAD_NORM = 45.0 / math.pi  # grad W normalisation of Eq. 4 (times det G)
K_R_DEFAULT = 4.0  # largest WPCA axis ratio (Yu & Turk 2013)


# ----------------------------------------------------------------------------- Taichi functions


@ti.func
def kernel_w(r, G):
    """W(r, G) of Eq. 4; r: vec3 (m), G: mat3 (1/m). Returns 1/m^3."""
    q = (G @ r).norm()
    w = 0.0
    if q < 1.0:
        w = KERNEL_NORM * G.determinant() * (1.0 - q) ** 3
    return w


@ti.func
def kernel_grad(r, G):
    """grad W(r, G) of Eq. 4 with respect to r; r: vec3 (m), G: symmetric mat3 (1/m). Returns 1/m^4."""
    Gr = G @ r
    q = Gr.norm()
    g = ti.Vector([0.0, 0.0, 0.0])
    if q < 1.0 and q > 0.0:
        g = (-GRAD_NORM * G.determinant() * (1.0 - q) ** 2 / q) * (G @ Gr)
    return g


@ti.func
def kernel_grad_weight(r, G):
    """The scalar k = 45/pi det(G) (1 - q)^2 / q with grad W(r) = -k G^2 r (0 outside or at r = 0)."""
    q = (G @ r).norm()
    k = 0.0
    if q < 1.0 and q > 0.0:
        k = GRAD_NORM * G.determinant() * (1.0 - q) ** 2 / q
    return k


@ti.func
def rotate_kernel(G0, M):
    """Eq. 6 in this project's convention: G_t = M G0 M^T for M mapping rest to current directions."""
    return M @ G0 @ M.transpose()


@ti.func
def support_radius_ti(G):
    """Largest semi-axis of the support ellipsoid |G r| < 1: 1 / lambda_min(G) (m)."""
    vals, _ = sym_eig3(G)
    return 1.0 / vals[2]


@ti.func
def support_extent(G):
    """Half-widths of the axis-aligned box around the support ellipsoid: sqrt(diag(G^-2)) (m)."""
    Gi = G.inverse()
    Gi2 = Gi @ Gi.transpose()
    return ti.Vector([ti.sqrt(Gi2[0, 0]), ti.sqrt(Gi2[1, 1]), ti.sqrt(Gi2[2, 2])])


# ----------------------------------------------------------------------------- numpy reference


def kernel_w_np(r: np.ndarray, G: np.ndarray) -> np.ndarray:
    """numpy W(r, G) for r (..., 3) and G (3,3) or (..., 3, 3)."""
    r = np.asarray(r, dtype=np.float64)
    G = np.asarray(G, dtype=np.float64)
    Gr = np.einsum("...ij,...j->...i", G, r)
    q = np.linalg.norm(Gr, axis=-1)
    det = np.linalg.det(G)
    return np.where(q < 1.0, KERNEL_NORM * det * np.clip(1.0 - q, 0.0, None) ** 3, 0.0)


def kernel_grad_np(r: np.ndarray, G: np.ndarray) -> np.ndarray:
    """numpy grad W(r, G) for r (..., 3) and G (3,3) or (..., 3, 3); 0 at r = 0 and outside."""
    r = np.asarray(r, dtype=np.float64)
    G = np.asarray(G, dtype=np.float64)
    Gr = np.einsum("...ij,...j->...i", G, r)
    q = np.linalg.norm(Gr, axis=-1)
    det = np.linalg.det(G)
    inside = (q < 1.0) & (q > 0.0)
    qs = np.where(inside, q, 1.0)
    k = np.where(inside, GRAD_NORM * det * (1.0 - qs) ** 2 / qs, 0.0)
    GGr = np.einsum("...ij,...j->...i", G, Gr)
    return -k[..., None] * GGr


def kernel_from_axes(axes: np.ndarray, lengths) -> np.ndarray:
    """Eq. 5: G = R diag(1/h_k) R^T; `axes` (3,3) has the kernel axes as columns (orthonormal),
    `lengths` (3,) the smoothing lengths h_k (m, support semi-axes)."""
    R = np.asarray(axes, dtype=np.float64)
    h = np.asarray(lengths, dtype=np.float64)
    if np.any(h <= 0.0):
        raise ValueError(f"kernel lengths must be positive, got {h}")
    return R @ np.diag(1.0 / h) @ R.T


def kernel_isotropic(h: float) -> np.ndarray:
    """G = I / h: isotropic kernel with support radius h (m)."""
    return np.eye(3) / float(h)


def rotate_kernel_np(G0: np.ndarray, M: np.ndarray) -> np.ndarray:
    """numpy Eq. 6 (this project's convention): M G0 M^T, M maps rest to current directions."""
    return np.einsum("...ij,...jk,...lk->...il", M, G0, M)


def support_radius_np(G: np.ndarray) -> np.ndarray:
    """1 / lambda_min(G) for (3,3) or (n,3,3) tensors (m)."""
    return 1.0 / np.linalg.eigvalsh(np.asarray(G, dtype=np.float64))[..., 0]


def shortest_axis_np(G: np.ndarray) -> np.ndarray:
    """1 / lambda_max(G): the shortest support semi-axis (m), for time-step rules."""
    return 1.0 / np.linalg.eigvalsh(np.asarray(G, dtype=np.float64))[..., -1]


def kernel_wpca(
    x: np.ndarray,
    h: float,
    k_r: float = K_R_DEFAULT,
    axis_scale=(1.0, 1.0, 1.0),
    min_neighbours: int = 6,
    cache: bool = False,
) -> np.ndarray:
    """Kernel tensors G (n,3,3) from weighted PCA of each particle's neighbourhood (see module doc).

    x: (n,3) positions (m); h: isotropic support radius (m) used for the neighbourhood and for the
    volume normalisation; k_r: largest axis-length ratio; axis_scale: factors on the sorted axes
    (major, middle, minor) applied after normalisation; min_neighbours: fewer (self included) keep I/h;
    cache: read and keep the result in the disk cache (geometry/build_cache.py; a scene's build: the
    pot's 6.5k particles take 0.15 s and the pet's 1 s, after 0.45 s of importing scipy).
    """
    x = np.asarray(x, dtype=np.float64)
    if k_r < 1.0:
        raise ValueError(f"k_r must be >= 1, got {k_r}")
    args = (x, float(h), float(k_r), np.asarray(axis_scale, dtype=np.float64), int(min_neighbours))
    if not cache:
        return _wpca(*args)

    from geometry.build_cache import cached_arrays, digest, package_version

    key = digest("wpca", f"{WPCA_VERSION} numpy {np.__version__} scipy {package_version('scipy')}", x.tobytes(),
                 h=args[1], k_r=args[2], axis_scale=tuple(map(float, args[3])), min_neighbours=args[4])
    got = cached_arrays("kernels", key, ("G",), lambda: dict(G=_wpca(*args)),
                        lambda hit: hit["G"].shape == (len(x), 3, 3) and bool(np.isfinite(hit["G"]).all()))
    return got["G"]


def _wpca(x: np.ndarray, h: float, k_r: float, scale: np.ndarray, min_neighbours: int) -> np.ndarray:
    """`kernel_wpca`'s computation (its arguments checked)."""
    from scipy.spatial import cKDTree

    n = x.shape[0]
    tree = cKDTree(x)
    pairs = tree.query_pairs(h, output_type="ndarray")
    ii = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(n)])
    jj = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(n)])
    d = np.linalg.norm(x[jj] - x[ii], axis=1)
    w = 1.0 - (d / h) ** 3
    wsum = np.bincount(ii, weights=w, minlength=n)
    count = np.bincount(ii, minlength=n)
    mean = np.stack([np.bincount(ii, weights=w * x[jj, a], minlength=n) for a in range(3)], axis=1)
    mean /= wsum[:, None]
    dx = x[jj] - mean[ii]
    cov = np.zeros((n, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = np.bincount(ii, weights=w * dx[:, a] * dx[:, b], minlength=n)
            cov[:, b, a] = cov[:, a, b]
    cov /= wsum[:, None, None]
    # C_i = R diag(s_1 >= s_2 >= s_3) R^T for all particles at once (LAPACK; eigh gives s ascending)
    vals, R = np.linalg.eigh(cov)
    vals, R = vals[:, ::-1], R[:, :, ::-1]
    flat = (count < min_neighbours) | (vals[:, 0] <= 0.0)
    s2 = np.maximum(vals, vals[:, :1] / k_r**2)  # clamp: h_1 / h_k <= k_r
    s2[flat] = 1.0
    s = np.sqrt(s2)
    lengths = h * s / np.cbrt(np.prod(s, axis=1))[:, None]  # h_1 h_2 h_3 = h^3: same det(G) as I/h
    G = np.einsum("nik,nk,njk->nij", R, 1.0 / (lengths * scale), R)
    G[flat] = np.eye(3) / h
    return G
