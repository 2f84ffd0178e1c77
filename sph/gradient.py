"""The SPH displacement gradient of Algorithm 1 (paper Eq. 7, 10): grad u_i = sum_j (u_j - u_i) (x) d_ij
over each member's own anisotropic kernel (Eq. 4), plain, with the Bonet-Lok correction, or by a
quadratic weighted least-squares fit (the default; docs/notes_cracks.md says why). On a started CPU
runtime the neighbour test and the per-member sums are Taichi kernels (sph/gradient_kernels.py; the
corrections are inverted here, by numpy, between the two sums). Otherwise (before Taichi starts, and
on CUDA) host numpy, vectorised over a padded (member, neighbour) layout in blocks that run on the
host's cores (core/host_threads.py); no Python loop per particle either way.
"""

from __future__ import annotations

import numpy as np

from core.errors import ConfigError
from core.host_threads import ordered_map
from sph.kernel import GRAD_NORM

CORRECTIONS = (0, 1, 2)  # gradient orders: plain SPH, Bonet-Lok, quadratic WLS
DET_TOL = 1e-6  # relative |det B_i| below which the Bonet-Lok correction falls back to I
QUAD_MIN = 9  # neighbours a quadratic fit needs at least (its 9 monomials)
QUAD_RCOND = 1e-6  # relative singular-value cut of the quadratic moment matrix (pseudo-inverse)
PAD_SLOTS = 1 << 16  # (member, neighbour) slots padded at once: a block's arrays stay in cache
RADIUS_BINS = 4  # neighbour searches per analysis, over members of similar support radius
BIN_MEMBERS = 64  # members per bin at least: a small neighbourhood is searched at once, in line
PAIR_CELLS = 1 << 22  # (member, local particle) tests per launch of the kernels' neighbour test (its lists' room)


def neighbour_pairs(x: np.ndarray, G: np.ndarray, members: np.ndarray, local: np.ndarray) -> tuple:
    """Pairs (e, j) with member members[e] and local particle j != it, |G_i (x_j - x_i)| < 1
    (gather with the member's own kernel, as sph/neighbours.py). Returns (owner e, index j), sorted."""
    if kernels_run():
        return _pairs_by_kernel(x, G, members, local)
    from scipy.spatial import cKDTree  # here, not at import: a run's start imports no scipy (geometry/build_cache.py)

    Gm = G[members]
    rho = 1.0 / np.linalg.eigvalsh(Gm)[:, 0]  # support radius: |G (x_j - x_i)| < 1 needs |x_j - x_i| < rho
    tl = cKDTree(x[local])
    n = np.int64(x.shape[0])

    def pairs_of(part: np.ndarray) -> np.ndarray:
        """Keys e n + j of the pairs of members `part`: candidates within their largest support radius,
        the kernel test in chunks of PAD_SLOTS candidates (its (pairs, 3, 3) temporaries stay in cache)."""
        sdm = cKDTree(x[members[part]]).sparse_distance_matrix(tl, float(rho[part].max()) * (1.0 + 1e-12),
                                                              output_type="ndarray")
        e_all, j_all = part[sdm["i"]].astype(np.int64), local[sdm["j"]].astype(np.int64)
        kept = [np.zeros(0, dtype=np.int64)]
        for a in range(0, e_all.size, PAD_SLOTS):
            e, j = e_all[a:a + PAD_SLOTS], j_all[a:a + PAD_SLOTS]
            i = members[e]
            q = np.linalg.norm(np.einsum("eab,eb->ea", Gm[e], x[j] - x[i]), axis=1)
            keep = (q < 1.0) & (j != i)
            kept.append(e[keep] * n + j[keep])
        return np.concatenate(kept)

    # members in RADIUS_BINS bins of similar rho, searched side by side (core/host_threads.py): one
    # search radius for all over-collected where children and parents mix, as in Pots
    bins = np.array_split(np.argsort(rho, kind="stable"), max(1, min(RADIUS_BINS, members.size // BIN_MEMBERS)))
    key = np.sort(np.concatenate(ordered_map(pairs_of, bins)))  # by (e, j)
    return key // n, key % n


def kernels_run() -> bool:
    """Whether the neighbour test and the gradient's sums run as Taichi kernels (sph/gradient_kernels.py):
    on a started CPU runtime. Before Taichi starts, and on CUDA (float64 local matrices fail there,
    docs/decisions.md "CUDA and f64"), the numpy code below runs: the same sums in another order."""
    from core.runtime import started_on_cpu

    return started_on_cpu()


def _pairs_by_kernel(x: np.ndarray, G: np.ndarray, members: np.ndarray, local: np.ndarray) -> tuple:
    """`neighbour_pairs` by one kernel over every (member, local particle), which lists the pairs."""
    from sph import gradient_kernels as gk

    local = np.sort(local)  # each member's neighbours listed in this order: sorted by (e, j) as the numpy path
    xl, il = gk.f64(x[local]), gk.i32(local)
    step = max(1, PAIR_CELLS // max(local.size, 1))
    owner, nbr = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    count = np.zeros(1, np.int32)
    for a in range(0, members.size, step):  # members in chunks: the lists' room stays under PAIR_CELLS pairs
        part = members[a:a + step]
        e, k = np.empty(part.size * local.size, np.int32), np.empty(part.size * local.size, np.int32)
        gk.k_pair_list(gk.f64(x[part]), gk.f64(G[part]), gk.i32(part), xl, il, e, k, count)
        owner.append(e[:count[0]].astype(np.int64) + a)
        nbr.append(local[k[:count[0]]].astype(np.int64))
    return np.concatenate(owner), np.concatenate(nbr)


def _quad_basis(X: np.ndarray) -> np.ndarray:
    """(E,9) linear and quadratic monomials of scaled offsets X (E,3)."""
    out = np.empty((X.shape[0], 9))
    out[:, :3] = X
    np.multiply(X, X, out=out[:, 3:6])
    np.multiply(X[:, 0], X[:, 1], out=out[:, 6])
    np.multiply(X[:, 0], X[:, 2], out=out[:, 7])
    np.multiply(X[:, 1], X[:, 2], out=out[:, 8])
    return out


def sph_gradient(
    x: np.ndarray,
    volume: np.ndarray,
    G: np.ndarray,
    u: np.ndarray,
    members: np.ndarray,
    owner: np.ndarray,
    nbr: np.ndarray,
    correction: bool | int = 2,
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 7 at each member: grad u_i = sum_j (u_j - u_i) (x) d_ij (module doc, step 5).

    x (N,3), volume (N,), G (N,3,3), u (N,3) (rows needed: members and their neighbours), pairs
    (owner, nbr) from `neighbour_pairs`. correction: 0/False plain SPH (Eq. 7 as printed),
    1/True Bonet-Lok, 2 quadratic weighted least squares. Returns (grad (M,3,3), order used (M,))."""
    order = int(correction)
    if order not in CORRECTIONS:
        raise ConfigError("analyse_impact.correction", correction, "0/False (plain), 1/True (Bonet-Lok), 2 (quadratic)")
    m = members.size
    used = np.zeros(m, dtype=np.int64)
    if owner.size == 0:
        return np.zeros((m, 3, 3)), used
    cnt = np.bincount(owner, minlength=m)
    start = np.concatenate([[0], np.cumsum(cnt)]).astype(np.int64)  # pairs of member e: start[e]..start[e+1]
    Gm = G[members]
    det = np.linalg.det(Gm)
    srad = 1.0 / np.linalg.eigvalsh(Gm)[:, 0] if order == 2 else None  # support radius: scales the basis
    if kernels_run():
        return _gradient_by_kernels(x, volume, u, members, nbr, order, cnt, start, Gm, GRAD_NORM * det, srad)
    K = int(cnt.max())
    grad = np.empty((m, 3, 3))
    # members in blocks of about PAD_SLOTS padded slots, every block padded to the same width K (so
    # each member's sums are the same arithmetic as in one block): a neighbourhood that holds a whole
    # fragment (1k members x 1k neighbours) pads to 10^6 slots, and blocks keep that in cache; the
    # per-pair kernel terms are made block by block too (pairs are sorted by owner)
    step = max(1, PAD_SLOTS // K)

    def block(a: int) -> None:
        b = min(m, a + step)
        pairs = slice(start[a], start[b])
        own, j = owner[pairs], nbr[pairs]
        i = members[own]
        xi = x[j] - x[i]
        Gi = np.repeat(Gm[a:b], cnt[a:b], axis=0)  # = Gm[own]
        Gx = np.einsum("eab,eb->ea", Gi, xi)
        q = np.linalg.norm(Gx, axis=1)
        inside = (q > 0.0) & (q < 1.0)
        qs = np.where(inside, q, 1.0)
        k = np.where(inside, GRAD_NORM * det[own] * (1.0 - qs) ** 2 / qs, 0.0)
        g = None  # grad W(x_i - x_j, G_i) = k G^2 (x_j - x_i): only the plain and Bonet-Lok weights use it
        if order < 2 or (cnt[a:b] < QUAD_MIN).any():
            g = k[:, None] * np.einsum("eab,eb->ea", Gi, Gx)
        grad[a:b], used[a:b] = _block_gradient(order, K, own - a, np.arange(start[a], start[b]) - start[own],
                                               xi, g, k, volume[j], u[j] - u[i], cnt[a:b],
                                               None if srad is None else srad[a:b])

    ordered_map(block, range(0, m, step))  # blocks side by side (core/host_threads.py), each in its rows
    return grad, used


def _block_gradient(order: int, K: int, owner, slot, xi, g, k, vol, du, cnt, srad) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 7 for a block of members: pair arrays (owner within the block, slot in its row, offset
    x_j - x_i, grad W, kernel factor, V_j, u_j - u_i) padded to (members, K); see `sph_gradient`."""
    m = cnt.size
    used = np.zeros(m, dtype=np.int64)

    flat = owner * K + slot  # each pair's row in the (members x K) padding

    def pad(vals: np.ndarray) -> np.ndarray:
        out = np.zeros((m * K,) + vals.shape[1:])
        out[flat] = vals
        return out.reshape((m, K) + vals.shape[1:])

    def rows(a: np.ndarray, sel: np.ndarray) -> np.ndarray:
        return a if sel.all() else a[sel]  # every member selected (the usual case): no copy

    quad = _fitted(order, cnt)
    rest = ~quad
    d = np.empty((m, K, 3))
    if rest.any():
        Vg = rows(pad(vol[:, None] * g), rest)  # plain SPH weights V_j grad W (Eq. 7, 10)
        d[rest] = Vg
        if order >= 1:
            L, ok = _bonet_lok(np.matmul(Vg.transpose(0, 2, 1), rows(pad(xi), rest)))  # sum_j V_j grad W (x) xi
            used[np.flatnonzero(rest)[ok]] = 1
            d[rest] = np.matmul(Vg, L.transpose(0, 2, 1))  # d_ij = L_i V_j grad W
    if quad.any():
        w = rows(pad(vol * k), quad)  # WLS weights V_j k_ij (the weights Bonet-Lok implies)
        pb = rows(pad(_quad_basis(xi / srad[owner, None])), quad)  # (q, K, 9)
        Mq = np.matmul(pb.transpose(0, 2, 1), w[:, :, None] * pb)
        Mi = _pinv(Mq)
        d[quad] = np.matmul(pb, Mi[:, :, :3]) * (w / srad[quad, None])[:, :, None]  # the linear terms
        used[quad] = 2
    grad = np.matmul(pad(du).transpose(0, 2, 1), d)  # sum_j (u_j - u_i) (x) d_ij
    return grad, used


def _fitted(order: int, cnt: np.ndarray) -> np.ndarray:
    """Members whose quadratic fit is taken (order 2, at least 9 neighbours for the 9 monomials); the
    others take Bonet-Lok (order >= 1) or plain SPH weights."""
    return cnt >= QUAD_MIN if order == 2 else np.zeros(cnt.size, dtype=bool)


def _bonet_lok(Bm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bonet-Lok's L_i = B_i^-1 of (M,3,3) sums B_i, where B_i is far enough from singular (else I), and
    which were inverted."""
    scale = np.sqrt((Bm * Bm).sum(axis=(1, 2)) / 3.0)
    det = np.linalg.det(Bm)
    ok = (scale > 0.0) & (np.abs(det) > DET_TOL * scale**3)
    L = np.tile(np.eye(3), (len(Bm), 1, 1))
    if ok.any():
        L[ok] = np.linalg.inv(Bm[ok])
    return L, ok


def _pinv(Mq: np.ndarray) -> np.ndarray:
    """The quadratic fit's (q,9,9) moment matrices, pseudo-inverted with the relative rank cut QUAD_RCOND."""
    return np.linalg.pinv(Mq, rcond=QUAD_RCOND, hermitian=True)


def _gradient_by_kernels(x, volume, u, members, nbr, order: int, cnt, start, Gm, coef, srad) -> tuple:
    """`sph_gradient` as kernel passes over each member's pairs (sph/gradient_kernels.py), the corrections'
    sums first, inverted by numpy, then Eq. 7's: the same weights, summed in pair order."""
    from sph import gradient_kernels as gk

    m = members.size
    quad = _fitted(order, cnt)
    x, volume, members, Gm, coef = gk.f64(x), gk.f64(volume), gk.i32(members), gk.f64(Gm), gk.f64(coef)
    srad = gk.f64(np.ones(m) if srad is None else srad)
    pairs = (gk.i32(start), gk.i32(nbr), gk.i32(quad))
    used = np.where(quad, 2, 0).astype(np.int64)
    Minv = np.zeros((m, 9, 3))
    if quad.any():
        moments = np.zeros((m, 9, 9))
        gk.k_fit_moments(x, volume, members, Gm, coef, srad, *pairs, moments)
        Minv[quad] = _pinv(moments[quad])[:, :, :3]
    L = np.tile(np.eye(3), (m, 1, 1))  # plain SPH weights: d_ij = V_j grad W
    rest = np.flatnonzero(~quad)
    if order >= 1 and rest.size:
        B = np.zeros((m, 3, 3))
        gk.k_bonet_lok_sums(x, volume, members, Gm, coef, *pairs, B)
        L[rest], ok = _bonet_lok(B[rest])
        used[rest[ok]] = 1
    grad = np.empty((m, 3, 3))
    gk.k_gradient_sums(x, volume, gk.f64(u), members, Gm, coef, srad, *pairs, Minv, L, grad)
    return grad, used
