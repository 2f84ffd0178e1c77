"""Linear elastic materials: 6x6 stiffness (Sect. 3, Hooke's law sigma = C eps) and validation.

Voigt convention (used everywhere in the project):
  order xx, yy, zz, yz, xz, xy (indices 0..5);
  strain vector with ENGINEERING shear: e = [e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy];
  stress vector: s = [s_xx, s_yy, s_zz, s_yz, s_xz, s_xy];  s = C e;
  energy density 1/2 eps:sigma = 1/2 e . s;  C_voigt[I, J] = C_ijkl with I <-> ij, J <-> kl.

Constructors (each validates and raises `core.errors.MaterialError(key_path, value, allowed)`):
  stiffness_isotropic(E, nu)                     -1 < nu < 1/2, E > 0
  stiffness_transverse(axis, E_axial, E_transverse, nu_transverse, nu_axial, G_axial)
      axis: symmetry axis; nu_transverse = in-plane Poisson ratio (strain in the plane from stress
      in the plane); nu_axial = -e_transverse / e_axial under stress along the axis (often nu_31);
      in-plane shear modulus E_transverse / (2 (1 + nu_transverse)).
  stiffness_orthotropic(E1, E2, E3, nu12, nu13, nu23, G12, G13, G23, axes)
      nu_ij = -e_j / e_i under uniaxial stress along i (so nu_ij / E_i = nu_ji / E_j);
      bounds |nu_ij| < sqrt(E_i / E_j) and compliance positive definite; axes: (3,3) whose columns
      are the material axes 1, 2, 3 in world coordinates (identity by default).
  stiffness_full(C)                              a symmetric positive definite 6x6, or its 21
      upper-triangle constants row by row (C11, C12, ..., C16, C22, ..., C66).
Rotation of a stiffness (`rotate_stiffness(C, Q)`): in tensor form,
C'_ijkl = Q_ia Q_jb Q_kc Q_ld C_abcd, with Q's columns the material axes in world coordinates.

`wave_speed_max(material)`: the largest phase velocity of any plane wave, i.e. max over unit
directions n of sqrt(lambda_max(Gamma(n)) / rho) with the Christoffel matrix
Gamma_ik = C_ijkl n_j n_l (for isotropic media the P-wave speed sqrt((lambda + 2 mu)/rho)).
It is found by sampling 2,000 directions and refining the best ones (Nelder-Mead on the sphere);
as a cross-check it never exceeds the strict bound sqrt(2 lambda_max(C_voigt) / rho) (the factor 2
comes from the engineering shear convention: |e|^2 <= 2 |eps|_F^2).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from core.errors import MaterialError
from sph.cleavage import Cleavage, cleavage_from_dict

VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))  # index pairs of Voigt slots 0..5
_SYM_RTOL = 1e-10  # relative asymmetry accepted in a full 6x6
ROTATIONS_KEPT = 64  # (stiffness, rotation) pairs whose turned stiffness is remembered (rotate_stiffness)


def _pos(key: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise MaterialError(key, value, "> 0 (finite)")
    return v


def _check_pd(C: np.ndarray, key: str) -> None:
    w = np.linalg.eigvalsh(0.5 * (C + C.T))
    if not (np.all(np.isfinite(w)) and w[0] > 0.0):
        raise MaterialError(key, float(w[0]), "positive definite 6x6 stiffness (smallest eigenvalue > 0)")


def voigt_to_tensor(C: np.ndarray) -> np.ndarray:
    """(6,6) Voigt stiffness (engineering shear) to the (3,3,3,3) tensor C_ijkl."""
    T = np.zeros((3, 3, 3, 3))
    for I_, (i, j) in enumerate(VOIGT_PAIRS):
        for J_, (k, m) in enumerate(VOIGT_PAIRS):
            v = C[I_, J_]
            for a, b in ((i, j), (j, i)):
                for c, d in ((k, m), (m, k)):
                    T[a, b, c, d] = v
    return T


def tensor_to_voigt(T: np.ndarray) -> np.ndarray:
    """(3,3,3,3) tensor to the (6,6) Voigt stiffness (engineering shear convention)."""
    C = np.zeros((6, 6))
    for I_, (i, j) in enumerate(VOIGT_PAIRS):
        for J_, (k, m) in enumerate(VOIGT_PAIRS):
            C[I_, J_] = T[i, j, k, m]
    return C


def strain_to_voigt(eps: np.ndarray) -> np.ndarray:
    """Symmetric strain tensor(s) (...,3,3) to Voigt vectors (...,6) with engineering shear."""
    e = np.asarray(eps)
    return np.stack(
        [e[..., 0, 0], e[..., 1, 1], e[..., 2, 2], 2 * e[..., 1, 2], 2 * e[..., 0, 2], 2 * e[..., 0, 1]],
        axis=-1,
    )


def stress_from_voigt(s: np.ndarray) -> np.ndarray:
    """Voigt stress vector(s) (...,6) to symmetric tensors (...,3,3)."""
    s = np.asarray(s)
    out = np.empty(s.shape[:-1] + (3, 3))
    for I_, (i, j) in enumerate(VOIGT_PAIRS):
        out[..., i, j] = s[..., I_]
        out[..., j, i] = s[..., I_]
    return out


def energy_density(C: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """1/2 eps : C : eps (J/m^3) for strain tensor(s) eps (...,3,3)."""
    e = strain_to_voigt(eps)
    return 0.5 * np.einsum("...i,ij,...j->...", e, C, e)


def rotate_stiffness(C: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """C expressed in material axes -> world: C'_ijkl = Q_ia Q_jb Q_kc Q_ld C_abcd (Q's columns =
    material axes in world coordinates, Q orthonormal). A fresh array, remembered by the bytes of C and Q:
    every impact analysis turns its object's material (World.object_material), 0.5 ms of einsum a time."""
    C = np.ascontiguousarray(C, dtype=np.float64)
    Q = np.ascontiguousarray(Q, dtype=np.float64)
    return _rotated(C.shape, C.tobytes(), Q.shape, Q.tobytes()).copy()


@functools.lru_cache(maxsize=ROTATIONS_KEPT)
def _rotated(c_shape: tuple, c_bytes: bytes, q_shape: tuple, q_bytes: bytes) -> np.ndarray:
    Q = np.frombuffer(q_bytes).reshape(q_shape)
    T = voigt_to_tensor(np.frombuffer(c_bytes).reshape(c_shape))
    return tensor_to_voigt(np.einsum("ia,jb,kc,ld,abcd->ijkl", Q, Q, Q, Q, T, optimize=True))


def _check_axes(axes, key: str) -> np.ndarray:
    Q = np.eye(3) if axes is None else np.asarray(axes, dtype=np.float64)
    if Q.shape != (3, 3) or not np.all(np.isfinite(Q)):
        raise MaterialError(key, axes, "3x3 matrix whose columns are orthonormal material axes")
    if np.abs(Q.T @ Q - np.eye(3)).max() > 1e-8 or np.linalg.det(Q) < 0.0:
        raise MaterialError(key, Q.tolist(), "orthonormal, right-handed columns (a rotation matrix)")
    return Q


def stiffness_isotropic(E: float, nu: float, key: str = "material") -> np.ndarray:
    """Isotropic 6x6 stiffness from Young's modulus E (Pa) and Poisson ratio nu."""
    E = _pos(f"{key}.E", E)
    nu_f = float(nu)
    if not (math.isfinite(nu_f) and -1.0 < nu_f < 0.5):
        raise MaterialError(f"{key}.nu", nu, "-1 < nu < 0.5")
    lam = E * nu_f / ((1.0 + nu_f) * (1.0 - 2.0 * nu_f))
    mu = E / (2.0 * (1.0 + nu_f))
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[[0, 1, 2], [0, 1, 2]] = lam + 2.0 * mu
    C[[3, 4, 5], [3, 4, 5]] = mu
    return C


def stiffness_orthotropic(
    E1: float,
    E2: float,
    E3: float,
    nu12: float,
    nu13: float,
    nu23: float,
    G12: float,
    G13: float,
    G23: float,
    axes=None,
    key: str = "material",
) -> np.ndarray:
    """Orthotropic 6x6 stiffness (Pa) in world axes; constants refer to the material axes (columns
    of `axes`). Compliance in material axes: S_ii = 1/E_i, S_ij = -nu_ij / E_i, S_44 = 1/G23,
    S_55 = 1/G13, S_66 = 1/G12 (Voigt order yz, xz, xy); C = S^-1, then rotated."""
    E = [_pos(f"{key}.E1", E1), _pos(f"{key}.E2", E2), _pos(f"{key}.E3", E3)]
    G = {"G23": _pos(f"{key}.G23", G23), "G13": _pos(f"{key}.G13", G13), "G12": _pos(f"{key}.G12", G12)}
    nus = {(0, 1): ("nu12", nu12), (0, 2): ("nu13", nu13), (1, 2): ("nu23", nu23)}
    S = np.zeros((6, 6))
    for a in range(3):
        S[a, a] = 1.0 / E[a]
    for (a, b), (name, v) in nus.items():
        v = float(v)
        bound = math.sqrt(E[a] / E[b])
        if not (math.isfinite(v) and abs(v) < bound):
            raise MaterialError(f"{key}.{name}", v, f"|{name}| < sqrt(E{a + 1}/E{b + 1}) = {bound:.6g}")
        S[a, b] = S[b, a] = -v / E[a]
    S[3, 3] = 1.0 / G["G23"]
    S[4, 4] = 1.0 / G["G13"]
    S[5, 5] = 1.0 / G["G12"]
    w = np.linalg.eigvalsh(S)
    if w[0] <= 0.0:
        n12, n13, n23 = float(nu12), float(nu13), float(nu23)
        n21, n31, n32 = n12 * E[1] / E[0], n13 * E[2] / E[0], n23 * E[2] / E[1]
        delta = 1.0 - n12 * n21 - n23 * n32 - n13 * n31 - 2.0 * n21 * n32 * n13
        raise MaterialError(
            f"{key}.(nu12, nu13, nu23)",
            (n12, n13, n23),
            f"compliance positive definite: 1 - nu12 nu21 - nu23 nu32 - nu13 nu31 - 2 nu21 nu32 nu13 > 0"
            f" (is {delta:.6g})",
        )
    C = np.linalg.inv(S)
    C = 0.5 * (C + C.T)
    Q = _check_axes(axes, f"{key}.axes")
    if not np.allclose(Q, np.eye(3), rtol=0.0, atol=0.0):
        C = rotate_stiffness(C, Q)
    _check_pd(C, f"{key}.stiffness")
    return C


def _frame_from_axis(axis, key: str) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64).reshape(-1)
    nrm = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if a.shape != (3,) or not math.isfinite(nrm) or nrm == 0.0:
        raise MaterialError(key, axis, "a non-zero 3-vector")
    a = a / nrm
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return np.column_stack([e1, e2, a])  # material axis 3 = symmetry axis


def stiffness_transverse(
    axis,
    E_axial: float,
    E_transverse: float,
    nu_transverse: float,
    nu_axial: float,
    G_axial: float,
    key: str = "material",
) -> np.ndarray:
    """Transversely isotropic 6x6 stiffness (Pa) in world axes; `axis` is the symmetry axis.

    Maps to orthotropic constants with material axis 3 = axis: E1 = E2 = E_transverse,
    E3 = E_axial, nu12 = nu_transverse, nu31 = nu_axial (so nu13 = nu_axial E_t / E_a),
    G13 = G23 = G_axial, G12 = E_t / (2 (1 + nu_t))."""
    Ea = _pos(f"{key}.E_axial", E_axial)
    Et = _pos(f"{key}.E_transverse", E_transverse)
    Ga = _pos(f"{key}.G_axial", G_axial)
    nt = float(nu_transverse)
    if not (math.isfinite(nt) and -1.0 < nt < 1.0):
        raise MaterialError(f"{key}.nu_transverse", nu_transverse, "-1 < nu_transverse < 1")
    na = float(nu_axial)
    bound = math.sqrt(Ea / Et)
    if not (math.isfinite(na) and abs(na) < bound):
        raise MaterialError(
            f"{key}.nu_axial", nu_axial, f"|nu_axial| < sqrt(E_axial/E_transverse) = {bound:.6g}"
        )
    Q = _frame_from_axis(axis, f"{key}.axis")
    nu13 = na * Et / Ea
    if 1.0 - nt * nt - 2.0 * na * nu13 * (1.0 + nt) <= 0.0:
        raise MaterialError(
            f"{key}.(nu_transverse, nu_axial)",
            (nt, na),
            "compliance positive definite: (1 + nu_t)(1 - nu_t - 2 nu_axial^2 E_t / E_a) > 0",
        )
    return stiffness_orthotropic(
        Et, Et, Ea, nt, nu13, nu13, Et / (2.0 * (1.0 + nt)), Ga, Ga, axes=Q, key=key
    )


def stiffness_full(C, key: str = "material") -> np.ndarray:
    """A full anisotropic stiffness: a (6,6) array or the 21 upper-triangle constants (Pa)."""
    arr = np.asarray(C, dtype=np.float64)
    if arr.shape == (21,):
        M = np.zeros((6, 6))
        M[np.triu_indices(6)] = arr
        M = M + np.triu(M, 1).T
        arr = M
    if arr.shape != (6, 6):
        raise MaterialError(f"{key}.stiffness", np.shape(C), "a 6x6 matrix or 21 upper-triangle constants")
    if not np.all(np.isfinite(arr)):
        raise MaterialError(f"{key}.stiffness", "non-finite entry", "finite values")
    scale = np.abs(arr).max()
    asym = np.abs(arr - arr.T)
    if asym.max() > _SYM_RTOL * scale:
        i, j = np.unravel_index(np.argmax(asym), asym.shape)
        raise MaterialError(
            f"{key}.stiffness[{i}][{j}]", (arr[i, j], arr[j, i]), f"symmetric: C[{i}][{j}] == C[{j}][{i}]"
        )
    arr = 0.5 * (arr + arr.T)
    _check_pd(arr, f"{key}.stiffness")
    return arr


def p_wave_modulus_max(C: np.ndarray) -> float:
    """max over unit directions n of lambda_max(Gamma(n)), Gamma_ik = C_ijkl n_j n_l (Pa)."""
    from scipy.optimize import minimize

    T = voigt_to_tensor(np.asarray(C, dtype=np.float64))

    def modulus(n: np.ndarray) -> np.ndarray:
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        gam = np.einsum("ijkl,...j,...l->...ik", T, n, n)
        return np.linalg.eigvalsh(gam)[..., -1]

    k = np.arange(2000) + 0.5  # Fibonacci sphere: near-uniform directions
    z = 1.0 - 2.0 * k / 2000
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    rr = np.sqrt(1.0 - z * z)
    dirs = np.stack([rr * np.cos(phi), rr * np.sin(phi), z], axis=1)
    dirs = np.vstack([dirs, np.eye(3)])
    vals = modulus(dirs)
    best = float(vals.max())
    for idx in np.argsort(-vals)[:4]:
        n0 = dirs[idx]
        th0, ph0 = math.acos(max(-1.0, min(1.0, n0[2]))), math.atan2(n0[1], n0[0])

        def neg(p: np.ndarray) -> float:
            n = np.array([math.sin(p[0]) * math.cos(p[1]), math.sin(p[0]) * math.sin(p[1]), math.cos(p[0])])
            return -float(modulus(n))

        opts = {"xatol": 1e-9, "fatol": 1e-14}
        res = minimize(neg, np.array([th0, ph0]), method="Nelder-Mead", options=opts)
        best = max(best, -float(res.fun))
    bound = 2.0 * float(np.linalg.eigvalsh(0.5 * (C + C.T))[-1])
    return min(best, bound)


@dataclass
class Material:
    """One elastic-brittle material (Sect. 3, 4.2, 5.3)."""

    name: str
    density: float  # kg/m^3
    stiffness: np.ndarray  # (6,6) Pa, Voigt xx, yy, zz, yz, xz, xy, engineering shear
    tensile_strength: float = 1.0e6  # Pa: Rankine threshold on the largest principal stress
    toughness: float = 10.0  # J/m^2: critical energy release rate G_c (Eq. 11)
    restitution: float = 0.3  # 1: coefficient of restitution in contacts
    friction: float = 0.5  # 1: Coulomb friction coefficient
    cleavage: Cleavage | dict | None = None  # weak planes: normal and strength across them (sph.cleavage)
    _c_max: float | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        key = f"materials.{self.name}"
        self.density = _pos(f"{key}.density", self.density)
        self.stiffness = stiffness_full(self.stiffness, key=key)
        self.tensile_strength = _pos(f"{key}.tensile_strength", self.tensile_strength)
        self.toughness = _pos(f"{key}.toughness", self.toughness)
        r = float(self.restitution)
        if not (math.isfinite(r) and 0.0 <= r <= 1.0):
            raise MaterialError(f"{key}.restitution", self.restitution, "0 <= restitution <= 1")
        self.restitution = r
        f = float(self.friction)
        if not (math.isfinite(f) and f >= 0.0):
            raise MaterialError(f"{key}.friction", self.friction, ">= 0")
        self.friction = f
        if isinstance(self.cleavage, dict):
            self.cleavage = cleavage_from_dict(self.cleavage, self.tensile_strength, f"{key}.cleavage")


def oriented(material: Material, R: np.ndarray) -> Material:
    """The material of an object turned by R (3,3), body -> reference frame: its stiffness axes and
    cleavage normal, given in the object's own frame like its kernel axes, turned with it."""
    R = np.asarray(R, dtype=np.float64)
    if np.allclose(R, np.eye(3), rtol=0.0, atol=1e-15):
        return material
    C = rotate_stiffness(material.stiffness, R)
    if np.allclose(C, material.stiffness, rtol=0.0, atol=1e-12 * float(np.abs(C).max())):
        C = material.stiffness  # isotropic: turning it would only change it by rounding
    cleavage = material.cleavage
    if cleavage is not None:
        cleavage = Cleavage(normal=R @ cleavage.normal, tensile_strength=cleavage.tensile_strength)
    elif C is material.stiffness:
        return material
    return replace(material, stiffness=C, cleavage=cleavage)


def wave_speed_max(material: Material) -> float:
    """Largest plane-wave phase speed (m/s): sqrt(max_n lambda_max(Gamma(n)) / rho); see module doc."""
    if material._c_max is None:
        material._c_max = math.sqrt(p_wave_modulus_max(material.stiffness) / material.density)
    return material._c_max


def material_from_dict(d: dict, key: str = "material") -> Material:
    """Build a Material from a scene dictionary. `model` is one of isotropic (E, nu), transverse
    (axis, E_axial, E_transverse, nu_transverse, nu_axial, G_axial), orthotropic (E1 .. G23, axes)
    or anisotropic (stiffness: 6x6 or 21 constants); plus density, tensile_strength, toughness,
    restitution, friction and cleavage (sph.cleavage). Unknown or missing keys raise MaterialError naming the key."""
    d = dict(d)
    model = d.pop("model", "isotropic")
    name = str(d.pop("name", key.split(".")[-1]))
    common = {k: d.pop(k) for k in ("tensile_strength", "toughness", "restitution", "friction", "cleavage") if k in d}
    if "density" not in d:
        raise MaterialError(f"{key}.density", None, "> 0 (kg/m^3), required")
    density = d.pop("density")
    params = {
        "isotropic": ("E", "nu"),
        "transverse": ("axis", "E_axial", "E_transverse", "nu_transverse", "nu_axial", "G_axial"),
        "orthotropic": ("E1", "E2", "E3", "nu12", "nu13", "nu23", "G12", "G13", "G23", "axes"),
        "anisotropic": ("stiffness",),
    }
    if model not in params:
        raise MaterialError(f"{key}.model", model, ", ".join(params))
    optional = {"axes"}
    args = {}
    for p in params[model]:
        if p in d:
            args[p] = d.pop(p)
        elif p not in optional:
            raise MaterialError(f"{key}.{p}", None, f"required for model '{model}'")
    if d:
        extra = sorted(d)[0]
        raise MaterialError(f"{key}.{extra}", d[extra], "not a key of model '" + model + "'")
    if model == "isotropic":
        C = stiffness_isotropic(args["E"], args["nu"], key=key)
    elif model == "transverse":
        C = stiffness_transverse(key=key, **args)
    elif model == "orthotropic":
        C = stiffness_orthotropic(key=key, **args)
    else:
        C = stiffness_full(args["stiffness"], key=key)
    return Material(name=name, density=density, stiffness=C, **common)
