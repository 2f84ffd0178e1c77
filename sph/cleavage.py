"""Tensile strength of a material with a plane of weakness (Sect. 4.2 lines 15-16, beyond the paper).

Layered and foliated rocks (slate's cleavage, shale's bedding) and laminates are much weaker when
pulled across their planes than along them: Brazilian tests on slate give 3-21 MPa depending on how
the load meets the foliation (Ghobadi & Behzadtabar 2018, J. Eng. Geol. 11(3); Meyers, "Strength of
Mintaro Shale", Australian Geomechanics: low anisotropy in compression, high in tension). The paper's
Rankine test takes one strength, so a slate and a marble struck the same way crack the same way. The
single-plane-of-weakness reading (Jaeger 1960, written here for tension): the material fails

    in the bulk,       where its largest principal tension reaches sigma_t, across that direction, or
    along its planes,  where the tension across them, a . sigma . a, reaches sigma_c (<= sigma_t),
                       and the crack then opens on the plane itself (normal a).

The bulk check takes the tensile part sigma+ that Algorithm 1 tests (O'Brien & Hodgins 1999); the
plane check the normal stress on the plane, a . sigma . a, so that a compression across the planes
keeps them shut (the Brazilian disc's load); both after the plane-stress projection where the wall is
thin. A group's crack lies on the planes when its mean tension across them (the weighted mean of the
members' max(a . sigma . a, 0)) uses more of sigma_c than its mean tension T_g uses of sigma_t. Both
checks are linear in the force, so the member test is written as an equivalent bulk tension (sigma_t
times the larger of the two utilisations), and the threshold speed, the onset energy and the shatter
radius follow from it unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import MaterialError


@dataclass(frozen=True)
class Cleavage:
    """A family of parallel weak planes."""

    normal: np.ndarray  # (3,) unit normal of the planes: the object's own frame (sph.materials.oriented turns it)
    tensile_strength: float  # Pa: strength across the planes, at most the bulk strength


def cleavage_from_dict(d: dict, bulk_strength: float, key: str) -> Cleavage:
    """`{normal = [x, y, z], tensile_strength = Pa}`; errors name the key, the value and the range."""
    d = dict(d)
    for name in ("normal", "tensile_strength"):
        if name not in d:
            raise MaterialError(f"{key}.{name}", None, "required")
    a = np.asarray(d.pop("normal"), dtype=np.float64).reshape(-1)
    norm = float(np.linalg.norm(a)) if a.size == 3 and np.all(np.isfinite(a)) else 0.0
    if norm == 0.0:
        raise MaterialError(f"{key}.normal", a.tolist(), "a non-zero finite 3-vector")
    s = float(d.pop("tensile_strength"))
    if not (math.isfinite(s) and 0.0 < s <= bulk_strength):
        allowed = f"0 < strength <= the bulk tensile_strength {bulk_strength:g} Pa"
        raise MaterialError(f"{key}.tensile_strength", s, allowed)
    if d:
        extra = sorted(d)[0]
        raise MaterialError(f"{key}.{extra}", d[extra], "not a key of cleavage (normal, tensile_strength)")
    return Cleavage(normal=a / norm, tensile_strength=s)


def tension_across(stress: np.ndarray, cleavage: Cleavage) -> np.ndarray:
    """(M,) Pa per newton: the tension across the weak planes, max(a . sigma . a, 0), of members'
    stresses (M,3,3) per newton (projected already): a compression across them keeps them shut."""
    a = cleavage.normal
    return np.maximum(np.einsum("i,mij,j->m", a, stress, a), 0.0)


def equivalent_tension(bulk: np.ndarray, across: np.ndarray | None, cleavage: Cleavage | None,
                       sigma_t: float) -> np.ndarray:
    """(M,) Pa per newton: sigma_t times the larger utilisation of the bulk (largest principal
    tension, bulk) and of the planes (across); the bulk tension alone without cleavage."""
    if cleavage is None:
        return bulk
    return np.maximum(bulk, across * (sigma_t / cleavage.tensile_strength))


def opens_on_plane(across_mean: float, bulk_max: float, cleavage: Cleavage | None, sigma_t: float) -> bool:
    """Whether a group's mean tension across the planes uses more of their strength than its mean
    tension's largest principal value (bulk_max) uses of the bulk's: its crack then lies on a plane."""
    if cleavage is None:
        return False
    return across_mean / cleavage.tensile_strength > bulk_max / sigma_t
