"""Corotated SPH elasticity with anisotropic kernels (Sect. 3-4.1: Eq. 1-3, 7-10).

Total-Lagrangian form: neighbours, kernel tensors G0_i and kernel gradients are taken in the rest
configuration x0 and never change (the body's rotation is removed by M_i, Eq. 3). Notation:
x_ji = x_j - x_i, xi_ij = x0_j - x0_i (rest offset), g_ij = grad W(x0_i - x0_j, G0_i) (Eq. 4, i's
kernel; gather over j in N(i), see sph/neighbours.py). Since grad W(r) = -k(q) G^2 r with
k = 45/pi det G (1 - q)^2 / q, g_ij = k_ij G0_i^2 xi_ij. The gradient operator of particle i is a
set of vectors d_ij (1/m) so that grad f_i = sum_j (f_j - f_i) (x) d_ij. Three orders:

  order 0, plain SPH (Eq. 7 and 10 as printed):  d_ij = V_j g_ij.
  order 1, Bonet-Lok correction:  B_i = sum_j V_j g_ij (x) xi_ij,  L_i = B_i^-1,  d_ij = V_j L_i g_ij.
      sum_j xi_ij (x) d_ij = I, so the gradient of any linear field is exact (surface included).
      This equals the weighted least-squares (WLS) linear fit with weights w_ij = V_j k_ij.
  order 2, quadratic consistency (an accuracy option beyond the paper, default of the elastic
      effect): the WLS fit of f_j - f_i by a linear plus quadratic polynomial in xi with the same
      weights w_ij; d_ij = w_ij [M_i^-1 p(xi_ij)]_{0..2}, M_i = sum_j w_ij p p^T, p = (xi, its six
      quadratic monomials), scaled by the support radius for conditioning. Gradients of quadratic
      fields are then exact at the particle. Why: at a free surface the neighbourhood is one-sided
      and the order-1 gradient of a bending field is the gradient at the neighbourhood's centroid,
      not at the particle: a beam 4 particles thick with h = 2 spacings stores only 77 % of the
      bending energy (+40 % tip deflection); order 2 stores the exact midpoint-rule value.
  Fallbacks (per particle, counted in `order_counts`): order 2 -> 1 when cond(M_i) > COND_MAX;
      order 1 -> 0 (L_i = I) when |det B_i| < DET_TOL (|B_i|_F / sqrt 3)^3, i.e. (nearly) coplanar
      or too small neighbourhoods.

  Deformation gradient F_i = sum_j x_ji (x) d_ij; Fc_i = F_i H_i^+ (H_i^+ the pseudo-inverse of H_i
      below): = F_i for orders 1-2, = F_i L_i^T for order 0, so the rotation always comes from a
      corrected estimate and Fc = I at rest (a projector for degenerate fallback neighbourhoods).
  Rotation M_i (Eq. 3): polar decomposition Fc_i = M_i S_i (ti.polar_decompose; in f64 its rotation
      is accurate to ~2e-10, which changes the symmetric strain only at second order).
  Displacement gradient (Eq. 2, 3, 7): grad u_i = sum_j (M_i^T x_ji - xi_ij) (x) d_ij
      = M_i^T F_i - H_i, H_i = sum_j xi_ij (x) d_ij (= I for orders 1 and 2). J_i = I + grad u_i;
      strain (Eq. 1) eps_i = (J + J^T)/2 - I; stress sigma_i = C eps_i (Voigt, sph/materials.py);
      energy (Eq. 8) U_i = V_i/2 eps_i : sigma_i.
  Forces (Eq. 9-10): every pair (i, j in N(i)) puts f_ji = -P_i d_ij on j and +P_i d_ij on i, with
      P_i = V_i M_i (I + grad u_i) sigma_i (rotated back to world by M_i). (I + grad u_i) is the
      paper's (I + grad u_i^T) written with (grad u)_kl = du_k/dX_l (the paper follows Mueller et al.
      2004, whose grad u is the transpose). With `green_factor=False`, P_i = V_i M_i sigma_i, the
      exact derivative of sum U_i for fixed M_i; they differ by O(|grad u| |sigma|). Equal and
      opposite pair forces: the internal forces sum to zero to round-off with one-sided lists.
  Zero-energy-mode stabilisation (alpha > 0). Gradient estimates are blind to displacement
      patterns that alternate between neighbours (hourglass modes). Let (Fc_i, Q_i) be the WLS fit
      of x_ji by Fc xi + Q p2(xi) (Q = 0 for orders 0 and 1) with weights w_ij. We add
          U_stab,i = kappa_i / 2 sum_j w_ij |e_ij|^2,  e_ij = x_ji - Fc_i xi_ij - Q_i p2(xi_ij),
          kappa_i = alpha Y V_i / sum_j w_ij |xi_ij|^2  (Y: the material's largest P-wave modulus).
      It vanishes for every motion the fit reproduces (affine motions; quadratic ones for order 2),
      so patch tests and rigid rotations are untouched. As (Fc_i, Q_i) minimise the sum, its exact
      gradient holds them fixed (envelope theorem): the pair gets -kappa_i w_ij e_ij on j and
      +kappa_i w_ij e_ij on i. Equal and opposite, and energy-consistent; counted as strain energy.
Storage: ti.ndarray passed to module-level kernels (compiled once per process for any store).
Forces are gathered (no atomics): particle j sums its own pairs and, through a transposed CSR
(built once with numpy, stable order), the pairs where it is the neighbour. Deterministic.
Rest data (d_ij, weights, fallbacks) are computed once on the host in float64 (numpy).
"""

import math

import numpy as np
import taichi as ti

from core.runtime import numpy_float
from sph.materials import p_wave_modulus_max
from sph.neighbours import NeighbourSearch

DET_TOL = 1e-6  # relative |det B_i| below which L_i falls back to I (rank-deficient neighbourhood)
COND_MAX = 1e4  # largest accepted condition number of the order-2 moment matrix M_i (scaled basis)
ORDERS = (0, 1, 2)

mat6 = ti.types.matrix(6, 6, float)
vec6 = ti.types.vector(6, float)
mat36 = ti.types.matrix(3, 6, float)


@ti.func
def strain_to_voigt_ti(e):
    """Symmetric strain -> Voigt vector (xx, yy, zz, 2yz, 2xz, 2xy)."""
    return vec6(e[0, 0], e[1, 1], e[2, 2], 2.0 * e[1, 2], 2.0 * e[0, 2], 2.0 * e[0, 1])


@ti.func
def voigt_to_stress_ti(s):
    """Voigt stress (xx, yy, zz, yz, xz, xy) -> symmetric tensor."""
    return ti.Matrix([[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]])


@ti.func
def quad_monomials(r):
    return vec6(r[0] * r[0], r[1] * r[1], r[2] * r[2], r[0] * r[1], r[0] * r[2], r[1] * r[2])


def _quad_np(r: np.ndarray) -> np.ndarray:
    x, y, z = r[:, 0], r[:, 1], r[:, 2]
    return np.stack([x * x, y * y, z * z, x * y, x * z, y * z], axis=1)


REST_CHUNK = 1 << 16  # neighbour entries processed at once on the host (bounds temporary memory)


def _seg(vals: np.ndarray, starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Per-particle sums of contiguous entry segments (vals (m, ...), starts/counts per particle)."""
    out = np.zeros((len(counts),) + vals.shape[1:])
    nz = counts > 0
    if nz.any():
        out[nz] = np.add.reduceat(vals, starts[nz], axis=0)
    return out


def _rest_chunk(x0, volume, G0, detG0, srad, idx, own, first, counts, order) -> dict:
    """rest_operators for particles first .. first + len(counts) (own: global owner of each entry)."""
    m = len(counts)
    loc = own - first  # owner index inside the block
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    xi = x0[idx] - x0[own]
    Gi = G0[own]
    Gxi = np.einsum("eab,eb->ea", Gi, xi)
    qn = np.linalg.norm(Gxi, axis=1)
    detG = detG0[own]
    inside = (qn > 0.0) & (qn < 1.0)
    qs = np.where(inside, qn, 1.0)
    k = np.where(inside, 45.0 / math.pi * detG * (1.0 - qs) ** 2 / qs, 0.0)
    g = k[:, None] * np.einsum("eab,eb->ea", Gi, Gxi)  # grad W(x0_i - x0_j, G0_i) = k G^2 xi
    Vj = volume[idx]
    w = Vj * k
    trA = _seg(w * np.einsum("ea,ea->e", xi, xi), starts, counts)

    B = _seg((Vj[:, None] * g)[:, :, None] * xi[:, None, :], starts, counts)
    s = np.sqrt((B * B).sum(axis=(1, 2)) / 3.0)
    detB = np.linalg.det(B)
    okL = (s > 0.0) & (np.abs(detB) > DET_TOL * s**3)
    L = np.tile(np.eye(3), (m, 1, 1))
    if okL.any():
        L[okL] = np.linalg.inv(B[okL])
    used = np.zeros(m, np.int64)
    q = np.zeros((len(idx), 6))
    if order == 0:
        d = Vj[:, None] * g
    else:
        d = Vj[:, None] * np.einsum("eab,eb->ea", L[loc], g)
        used[okL] = 1
    if order == 2:
        se = srad[own]  # support radius of the owner: scales the basis
        P = np.concatenate([xi / se[:, None], _quad_np(xi) / (se**2)[:, None]], axis=1)  # (e, 9)
        M = _seg(w[:, None, None] * P[:, :, None] * P[:, None, :], starts, counts)
        ev = np.linalg.eigvalsh(M)
        ok2 = (ev[:, 0] > 0.0) & (ev[:, -1] < COND_MAX * np.maximum(ev[:, 0], 1e-300))
        if ok2.any():
            Minv = np.zeros_like(M)
            Minv[ok2] = np.linalg.inv(M[ok2])
            sel = ok2[loc]
            c = np.einsum("eab,eb->ea", Minv[loc[sel]], P[sel]) * w[sel, None]
            d[sel] = c[:, :3] / se[sel, None]
            q[sel] = c[:, 3:] / (se[sel] ** 2)[:, None]
            used[ok2] = 2
    H = _seg(xi[:, :, None] * d[:, None, :], starts, counts)
    return {"d": d, "q": q, "w": w, "H": H, "used_order": used, "trA": trA}


def rest_operators(
    x0: np.ndarray,
    volume: np.ndarray,
    G0: np.ndarray,
    off: np.ndarray,
    idx: np.ndarray,
    order: int,
) -> dict:
    """Host-side rest data of the gradient operator (float64), see module doc.

    Returns d (nnz,3), q (nnz,6) quadratic-fit weights (zero unless order 2), w (nnz,) WLS weights
    V_j k_ij, Lrot (n,3,3), H (n,3,3), used_order (n,), trA (n,) = sum_j w_ij |xi_ij|^2 and own (nnz,).
    Particles are processed in blocks of about REST_CHUNK entries to bound the host memory.
    """
    n = x0.shape[0]
    nnz = idx.shape[0]
    counts = np.diff(off)
    own = np.repeat(np.arange(n), counts)
    detG0 = np.linalg.det(G0)
    srad = 1.0 / np.linalg.eigvalsh(G0)[:, 0]
    res = {"d": np.zeros((nnz, 3)), "q": np.zeros((nnz, 6)), "w": np.zeros(nnz), "H": np.zeros((n, 3, 3)),
           "used_order": np.zeros(n, np.int64), "trA": np.zeros(n)}
    a = 0
    while a < n:
        b = int(np.searchsorted(off, off[a] + REST_CHUNK, side="right")) - 1
        b = min(max(b, a + 1), n)
        ea, eb = int(off[a]), int(off[b])
        part = _rest_chunk(x0, volume, G0, detG0, srad, idx[ea:eb], own[ea:eb], a, counts[a:b], order)
        for key in ("d", "q", "w"):
            res[key][ea:eb] = part[key]
        for key in ("H", "used_order", "trA"):
            res[key][a:b] = part[key]
        a = b
    # Fc = F H^+ is the rotation's source: = F for orders 1-2 (H = I), = F L^T for order 0 (H = B^T),
    # and a projector at rest for degenerate (fallback) neighbourhoods. Stored transposed as Lrot.
    res["Lrot"] = np.swapaxes(np.linalg.pinv(res["H"], rcond=1e-10), 1, 2)
    res["own"] = own
    return res


nd_i32 = ti.types.ndarray(dtype=ti.i32, ndim=1)
nd_f = ti.types.ndarray(ndim=1)  # floats of the running precision
nd_v3 = ti.types.ndarray(dtype=ti.math.vec3, ndim=1)
nd_v6 = ti.types.ndarray(dtype=vec6, ndim=1)
nd_m3 = ti.types.ndarray(dtype=ti.math.mat3, ndim=1)
nd_m6 = ti.types.ndarray(dtype=mat6, ndim=1)


@ti.func
def stress_at(
    i, x: ti.template(), x0: ti.template(), vol: ti.template(), mat: ti.template(), Lrot: ti.template(),
    H: ti.template(), C: ti.template(), off: ti.template(), idx: ti.template(), d: ti.template(),
    q: ti.template(), w: ti.template(), r: ti.template(), F_out: ti.template(), R_out: ti.template(),
    gradu: ti.template(), strain: ti.template(), stress: ti.template(), energy: ti.template(),
    estab: ti.template(), P: ti.template(), quad: ti.template(), stab: ti.template(), green: ti.template(),
):
    """Eq. 3, 7, 1, 8 (+ stabilisation residuals) for particle i at the current positions x."""
    xi = x[i]
    F = ti.Matrix.zero(float, 3, 3)
    Q = mat36(0.0)
    for e in range(off[i], off[i + 1]):
        rij = x[idx[e]] - xi
        F += rij.outer_product(d[e])
        if ti.static(quad):
            Q += rij.outer_product(q[e])
    Fc = F @ Lrot[i].transpose()
    R, _S = ti.polar_decompose(Fc)
    gu = R.transpose() @ F - H[i]
    eps = 0.5 * (gu + gu.transpose())
    ev = strain_to_voigt_ti(eps)
    sv = C[mat[i]] @ ev
    sig = voigt_to_stress_ti(sv)
    V = vol[i]
    F_out[i] = Fc
    R_out[i] = R
    gradu[i] = gu
    strain[i] = eps
    stress[i] = sig
    energy[i] = 0.5 * V * ev.dot(sv)
    if ti.static(green):
        P[i] = V * (R @ ((ti.Matrix.identity(float, 3) + gu) @ sig))
    else:
        P[i] = V * (R @ sig)
    if ti.static(stab):
        x0i = x0[i]
        us = 0.0
        for e in range(off[i], off[i + 1]):
            j = idx[e]
            xi0 = x0[j] - x0i
            res = (x[j] - xi) - Fc @ xi0
            if ti.static(quad):
                res -= Q @ quad_monomials(xi0)
            wr = w[e] * res
            r[e] = wr
            us += 0.5 * wr.dot(res)
        estab[i] = us


@ti.func
def force_at(
    j, P: ti.template(), d: ti.template(), r: ti.template(), off: ti.template(), tr_off: ti.template(),
    tr_entry: ti.template(), tr_src: ti.template(), tr_d: ti.template(), stab: ti.template(),
):
    """Internal force on particle j (Eq. 9-10 plus stabilisation), gathered from all its pairs."""
    Pj = P[j]
    f = ti.Vector([0.0, 0.0, 0.0])
    for e in range(off[j], off[j + 1]):  # pairs owned by j: +P_j d_je (+ stabilisation)
        f += Pj @ d[e]
        if ti.static(stab):
            f += r[e]
    for t in range(tr_off[j], tr_off[j + 1]):  # pairs (i, j) owned by i: -P_i d_ij
        f -= P[tr_src[t]] @ tr_d[t]  # d_ij read in sequence (tr_d), not gathered from d
        if ti.static(stab):
            f -= r[tr_entry[t]]
    return f


@ti.kernel
def _k_stress(
    x: nd_v3, x0: nd_v3, vol: nd_f, mat: nd_i32, Lrot: nd_m3, H: nd_m3, C: nd_m6, off: nd_i32, idx: nd_i32,
    d: nd_v3, q: nd_v6, w: nd_f, r: nd_v3, F: nd_m3, R: nd_m3, gradu: nd_m3, strain: nd_m3, stress: nd_m3,
    energy: nd_f, estab: nd_f, P: nd_m3, n: ti.i32,
    quad: ti.template(), stab: ti.template(), green: ti.template(),
):
    for i in range(n):
        stress_at(i, x, x0, vol, mat, Lrot, H, C, off, idx, d, q, w, r, F, R, gradu, strain, stress, energy,
                  estab, P, quad, stab, green)


@ti.kernel
def _k_forces(
    x: nd_v3, x0: nd_v3, vol: nd_f, mat: nd_i32, Lrot: nd_m3, H: nd_m3, C: nd_m6, off: nd_i32, idx: nd_i32,
    d: nd_v3, q: nd_v6, w: nd_f, r: nd_v3, F: nd_m3, R: nd_m3, gradu: nd_m3, strain: nd_m3, stress: nd_m3,
    energy: nd_f, estab: nd_f, P: nd_m3, tr_off: nd_i32, tr_entry: nd_i32, tr_src: nd_i32, tr_d: nd_v3,
    force: nd_v3, n: ti.i32, quad: ti.template(), stab: ti.template(), green: ti.template(),
):
    for i in range(n):
        stress_at(i, x, x0, vol, mat, Lrot, H, C, off, idx, d, q, w, r, F, R, gradu, strain, stress, energy,
                  estab, P, quad, stab, green)
    for j in range(n):
        force[j] = force_at(j, P, d, r, off, tr_off, tr_entry, tr_src, tr_d, stab)


@ti.kernel
def _k_plain_gradient(x: nd_v3, x0: nd_v3, off: nd_i32, idx: nd_i32, d: nd_v3, gradu: nd_m3, n: ti.i32):
    for i in range(n):
        xi = x[i]
        x0i = x0[i]
        gu = ti.Matrix.zero(float, 3, 3)
        for e in range(off[i], off[i + 1]):
            j = idx[e]
            gu += ((x[j] - xi) - (x0[j] - x0i)).outer_product(d[e])
        gradu[i] = gu


def _nd(dtype, data: np.ndarray):
    """A ti.ndarray holding `data` (numpy); floats are cast to the running precision."""
    arr = np.ascontiguousarray(data)
    if np.issubdtype(arr.dtype, np.floating):
        arr = arr.astype(numpy_float())
    out = ti.ndarray(dtype, shape=arr.shape[0])
    out.from_numpy(arr)
    return out



def _checked_inputs(x0, volume, G0, stiffness, material_id, order):
    """CorotatedSPH's inputs as float64 arrays (x0 (n,3), volume (n,), G0 (n,3,3), stiffness list,
    material ids (n,)); ValueError naming the first bad one."""
    x0 = np.asarray(x0, dtype=np.float64)
    n = x0.shape[0]
    volume = np.asarray(volume, dtype=np.float64).reshape(-1)
    G0 = np.asarray(G0, dtype=np.float64)
    if G0.shape == (3, 3):
        G0 = np.broadcast_to(G0, (n, 3, 3)).copy()
    if n == 0 or x0.shape != (n, 3) or volume.shape != (n,) or G0.shape != (n, 3, 3):
        raise ValueError(f"CorotatedSPH: x0 (n,3), volume (n,), G0 (n,3,3); got {x0.shape}, {volume.shape}, {G0.shape}")
    Cs = stiffness if isinstance(stiffness, list | tuple) else [stiffness]
    Cs = [np.asarray(C, dtype=np.float64) for C in Cs]
    mid = np.zeros(n, np.int64) if material_id is None else np.asarray(material_id, np.int64).reshape(-1)
    if mid.shape != (n,) or mid.min() < 0 or mid.max() >= len(Cs):
        raise ValueError("CorotatedSPH: material_id must index the stiffness list")
    if order not in ORDERS:
        raise ValueError(f"CorotatedSPH: order must be one of {ORDERS}, got {order}")
    return x0, volume, G0, Cs, mid


def _padded(a: np.ndarray, dtype, m: int) -> np.ndarray:
    """The first m rows of a in a buffer of at least one row (a Taichi ndarray cannot be empty)."""
    buf = np.zeros((max(m, 1),) + a.shape[1:], dtype)
    buf[:m] = a[:m]
    return buf

class CorotatedSPH:
    """Rest data, neighbour CSR and per-particle elastic state for corotated SPH (module doc).

    x0 (n,3) m rest positions; volume (n,) m^3; G0 (n,3,3) or (3,3) 1/m rest kernel tensors;
    stiffness: (6,6) Pa or a list of them (one per material); material_id (n,) indices into it;
    order: 0 plain SPH, 1 Bonet-Lok corrected, 2 quadratic-consistent; stabilisation: alpha of
    U_stab (0 = off); green_factor: keep the paper's (I + grad u) factor in Eq. 9.
    Storage is `ti.ndarray` (module-level kernels compile once per process, whatever the store).
    """

    def __init__(
        self,
        x0: np.ndarray,
        volume: np.ndarray,
        G0: np.ndarray,
        stiffness,
        material_id: np.ndarray | None = None,
        order: int = 1,
        stabilisation: float = 0.0,
        green_factor: bool = True,
    ) -> None:
        x0, volume, G0, Cs, mid = _checked_inputs(x0, volume, G0, stiffness, material_id, order)
        n = x0.shape[0]
        self.n = n
        self.order = int(order)
        self.stabilisation = float(stabilisation)
        self.green_factor = bool(green_factor)
        stab = self.stabilisation > 0.0
        quad = stab and self.order == 2
        self.flags = (quad, stab, self.green_factor)  # template flags of the kernels

        ns = NeighbourSearch(n)
        ns.set_points(x0, G0)
        ns.build()
        off, idx = ns.to_numpy()
        ns.release()
        nnz = int(off[-1])
        self.nnz = nnz
        rest = rest_operators(x0, volume, G0, off, idx, self.order)
        own = rest["own"]
        Y = np.array([p_wave_modulus_max(C) for C in Cs])
        trA = rest["trA"]
        kappa = np.where(trA > 0.0, self.stabilisation * Y[mid] * volume / np.where(trA > 0.0, trA, 1.0), 0.0)
        order_tr = np.argsort(idx, kind="stable")  # transposed CSR: entries grouped by neighbour
        tr_off = np.concatenate([[0], np.cumsum(np.bincount(idx, minlength=n))])
        self.order_counts = {o: int((rest["used_order"] == o).sum()) for o in ORDERS}

        def pad(a: np.ndarray, dtype, use: bool = True) -> np.ndarray:
            return _padded(a, dtype, nnz if use else 0)

        i32, v3, m3 = ti.i32, ti.math.vec3, ti.math.mat3
        # fixed (rest) data
        self.particle_x0 = _nd(v3, x0)  # (n,) m: rest position
        self.particle_vol = _nd(float, volume)  # (n,) m^3: volume V_i
        self.particle_mat = _nd(i32, mid.astype(np.int32))  # (n,) 1: material index
        self.particle_Lrot = _nd(m3, rest["Lrot"])  # (n,) 1: (H_i^+)^T, so Fc_i = F_i Lrot_i^T
        self.particle_H = _nd(m3, rest["H"])  # (n,) 1: sum_j xi_ij (x) d_ij (I if corrected)
        self.nbr_offset = _nd(i32, off.astype(np.int32))  # (n+1,) 1: CSR offsets of N(i)
        self.nbr_index = _nd(i32, pad(idx, np.int32))  # (nnz,) 1: neighbour ids j
        self.nbr_d = _nd(v3, pad(rest["d"], np.float64))  # (nnz,) 1/m: gradient weights d_ij (Eq. 10)
        self.nbr_q = _nd(vec6, pad(rest["q"], np.float64, quad))  # (nnz or 1,) 1/m^2: quadratic-fit weights
        self.nbr_w = _nd(float, pad(kappa[own] * rest["w"], np.float64, stab))  # (nnz or 1,) N/m: kappa w_ij
        self.tr_offset = _nd(i32, tr_off.astype(np.int32))  # (n+1,) 1: offsets of pairs with j as neighbour
        self.tr_entry = _nd(i32, pad(order_tr, np.int32))  # (nnz,) 1: entry e of pair (i, j) in i's list
        self.tr_src = _nd(i32, pad(own[order_tr], np.int32))  # (nnz,) 1: owner i of that entry
        self.tr_d = _nd(v3, pad(rest["d"][order_tr], np.float64))  # (nnz,) 1/m: d_ij in this order (force pass)
        self.material_C = _nd(mat6, np.stack(Cs))  # (n_mat,) Pa: Voigt stiffness
        # changing data
        z3 = np.zeros((n, 3))
        z33 = np.zeros((n, 3, 3))
        self.particle_x = _nd(v3, x0)  # (n,) m: current position
        self.particle_F = _nd(m3, z33)  # (n,) 1: corrected deformation gradient Fc_i
        self.particle_R = _nd(m3, z33)  # (n,) 1: rotation M_i (Eq. 3)
        self.particle_gradu = _nd(m3, z33)  # (n,) 1: corotated grad u_i (Eq. 7)
        self.particle_strain = _nd(m3, z33)  # (n,) 1: eps_i (Eq. 1)
        self.particle_stress = _nd(m3, z33)  # (n,) Pa: sigma_i = C eps_i
        self.particle_energy = _nd(float, np.zeros(n))  # (n,) J: U_i (Eq. 8)
        self.particle_energy_stab = _nd(float, np.zeros(n))  # (n,) J: stabilisation energy U_stab,i
        self.particle_P = _nd(m3, z33)  # (n,) N m: V_i M_i (I + grad u_i) sigma_i
        self.particle_force = _nd(v3, z3)  # (n,) N: internal elastic force
        self.nbr_r = _nd(v3, pad(np.zeros((nnz, 3)), np.float64, stab))  # (nnz or 1,) N: kappa_i w_ij e_ij
        # argument groups of stress_at / force_at (kernel signatures follow this order)
        self.stress_args = (
            self.particle_x, self.particle_x0, self.particle_vol, self.particle_mat, self.particle_Lrot,
            self.particle_H, self.material_C, self.nbr_offset, self.nbr_index, self.nbr_d, self.nbr_q,
            self.nbr_w, self.nbr_r, self.particle_F, self.particle_R, self.particle_gradu,
            self.particle_strain,
            self.particle_stress, self.particle_energy, self.particle_energy_stab, self.particle_P,
        )
        self.force_args = (self.tr_offset, self.tr_entry, self.tr_src, self.tr_d)

    def release(self) -> None:
        """Drop the device arrays (no field tree is held)."""
        for k in list(vars(self)):
            if k.startswith(("particle_", "nbr_", "tr_", "material_")) or k.endswith("_args"):
                setattr(self, k, None)

    # ------------------------------------------------------------------ host API

    def set_positions(self, x: np.ndarray) -> None:
        """Current positions (n,3) m."""
        x = np.asarray(x)
        if x.shape != (self.n, 3):
            raise ValueError(f"set_positions: expected ({self.n}, 3), got {x.shape}")
        self.particle_x.from_numpy(np.ascontiguousarray(x, dtype=numpy_float()))

    def compute_stress(self) -> None:
        """F, M, grad u, strain, stress, energy and P (+ stabilisation) for the current positions."""
        _k_stress(*self.stress_args, self.n, *self.flags)

    def compute_forces(self) -> np.ndarray:
        """Stress and internal forces (n,3) N for the current positions."""
        _k_forces(*self.stress_args, *self.force_args, self.particle_force, self.n, *self.flags)
        return self.particle_force.to_numpy()

    def strain_energy(self) -> tuple[float, float]:
        """(sum_i U_i, sum_i U_stab,i) in J for the current positions (computes the stress first)."""
        self.compute_stress()
        return float(self.particle_energy.to_numpy().sum()), float(self.particle_energy_stab.to_numpy().sum())

    def plain_gradient(self) -> np.ndarray:
        """Eq. 2 without rotation: grad u_i = sum_j (u_j - u_i) (x) d_ij with u = x - x0; (n,3,3)."""
        _k_plain_gradient(self.particle_x, self.particle_x0, self.nbr_offset, self.nbr_index, self.nbr_d,
                          self.particle_gradu, self.n)
        return self.particle_gradu.to_numpy()

    def neighbour_counts(self) -> np.ndarray:
        return np.diff(self.nbr_offset.to_numpy())
