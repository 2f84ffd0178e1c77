"""sph.materials: stiffness constructors, validation errors, rotation, wave speed."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core.errors import MaterialError
from sph.materials import (
    Material,
    energy_density,
    material_from_dict,
    p_wave_modulus_max,
    rotate_stiffness,
    stiffness_full,
    stiffness_isotropic,
    stiffness_orthotropic,
    stiffness_transverse,
    strain_to_voigt,
    tensor_to_voigt,
    voigt_to_tensor,
    wave_speed_max,
)

WOOD = dict(E1=12e9, E2=0.9e9, E3=0.5e9, nu12=0.4, nu13=0.45, nu23=0.5, G12=0.7e9, G13=0.6e9, G23=0.1e9)


def test_isotropic_lame_and_hooke():
    E, nu = 100e6, 0.3
    C = stiffness_isotropic(E, nu)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    assert C[0, 0] == pytest.approx(lam + 2 * mu) and C[0, 1] == pytest.approx(lam)
    assert C[3, 3] == pytest.approx(mu) and C[5, 5] == pytest.approx(mu)
    # uniaxial stress: eps = sigma/E along x, -nu sigma/E across -> sigma_xx = E eps_xx, others 0
    eps = np.diag([1e-3, -nu * 1e-3, -nu * 1e-3])
    s = C @ strain_to_voigt(eps)
    np.testing.assert_allclose(s, [E * 1e-3, 0, 0, 0, 0, 0], atol=1e-6 * E * 1e-3)
    # engineering shear: sigma_xy = 2 mu eps_xy; energy density = 1/2 eps:sigma
    eps = np.zeros((3, 3))
    eps[0, 1] = eps[1, 0] = 1e-3
    s = C @ strain_to_voigt(eps)
    assert s[5] == pytest.approx(2 * mu * 1e-3)
    assert energy_density(C, eps) == pytest.approx(0.5 * 2 * s[5] * 1e-3)


def test_orthotropic_and_transverse_reduce_to_isotropic():
    E, nu = 70e9, 0.25
    G = E / (2 * (1 + nu))
    Ci = stiffness_isotropic(E, nu)
    Co = stiffness_orthotropic(E, E, E, nu, nu, nu, G, G, G, axes=Rotation.random(random_state=1).as_matrix())
    np.testing.assert_allclose(Co, Ci, rtol=1e-10, atol=1e-6 * E)
    Ct = stiffness_transverse([1, 2, 3], E, E, nu, nu, G)
    np.testing.assert_allclose(Ct, Ci, rtol=1e-10, atol=1e-6 * E)


def test_orthotropic_compliance_entries():
    C = stiffness_orthotropic(**WOOD)
    S = np.linalg.inv(C)
    assert 1 / S[0, 0] == pytest.approx(WOOD["E1"]) and 1 / S[2, 2] == pytest.approx(WOOD["E3"])
    assert -S[0, 1] * WOOD["E1"] == pytest.approx(WOOD["nu12"])  # nu12 = -e2/e1 under sigma_1
    assert -S[1, 2] * WOOD["E2"] == pytest.approx(WOOD["nu23"])
    assert 1 / S[3, 3] == pytest.approx(WOOD["G23"]) and 1 / S[5, 5] == pytest.approx(WOOD["G12"])
    np.testing.assert_allclose(C, C.T)


def test_transverse_axis_is_the_stiff_direction():
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    C = stiffness_transverse(axis, E_axial=10e9, E_transverse=1e9, nu_transverse=0.3, nu_axial=0.3, G_axial=0.5e9)
    # uniaxial stress along the axis: strain along the axis = sigma / E_axial
    S = np.linalg.inv(C)
    sig = np.outer(axis, axis)
    sv = np.array([sig[0, 0], sig[1, 1], sig[2, 2], sig[1, 2], sig[0, 2], sig[0, 1]])
    ev = S @ sv
    eps = np.array([[ev[0], ev[5] / 2, ev[4] / 2], [ev[5] / 2, ev[1], ev[3] / 2], [ev[4] / 2, ev[3] / 2, ev[2]]])
    assert axis @ eps @ axis == pytest.approx(1 / 10e9, rel=1e-10)
    # transverse strain = -nu_axial / E_axial
    assert np.array([0, 0, 1.0]) @ eps @ np.array([0, 0, 1.0]) == pytest.approx(-0.3 / 10e9, rel=1e-10)


def test_full_21_constants_roundtrip():
    C = stiffness_orthotropic(**WOOD, axes=Rotation.random(random_state=3).as_matrix())
    tri = C[np.triu_indices(6)]
    np.testing.assert_allclose(stiffness_full(tri), C)
    np.testing.assert_allclose(stiffness_full(C), C)


def test_rotated_orthotropic_energy_equals_rotated_strain():
    """Energy of strain eps with the material rotated by Q equals the energy of Q^T eps Q unrotated."""
    rng = np.random.default_rng(2)
    C = stiffness_orthotropic(**WOOD)
    for seed in range(5):
        Q = Rotation.random(random_state=seed).as_matrix()
        Cw = rotate_stiffness(C, Q)
        m = rng.standard_normal((3, 3)) * 1e-3
        eps = 0.5 * (m + m.T)
        assert energy_density(Cw, eps) == pytest.approx(energy_density(C, Q.T @ eps @ Q), rel=1e-12)
        np.testing.assert_allclose(stiffness_orthotropic(**WOOD, axes=Q), Cw, rtol=1e-12, atol=1e-9 * C.max())
    # 90 degrees about z swaps the roles of axes 1 and 2
    Rz = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    Cz = rotate_stiffness(C, Rz)
    assert Cz[1, 1] == pytest.approx(C[0, 0]) and Cz[0, 0] == pytest.approx(C[1, 1])


def test_a_remembered_rotation_is_the_computed_one_and_a_fresh_array():
    """rotate_stiffness remembers its answers (every impact analysis turns its object's material): a
    repeated call gives the einsum's bits again, in an array of its own that the caller may change."""
    C = stiffness_orthotropic(**WOOD)
    Q = Rotation.from_euler("xyz", [15.0, 0.0, 5.0], degrees=True).as_matrix()
    T = voigt_to_tensor(C)
    want = tensor_to_voigt(np.einsum("ia,jb,kc,ld,abcd->ijkl", Q, Q, Q, Q, T, optimize=True))
    first = rotate_stiffness(C, Q)
    first[0, 0] = -1.0  # the caller's own copy
    again = rotate_stiffness(C, Q)
    assert again is not first and np.array_equal(again, want)


BAD = [
    (lambda: stiffness_isotropic(0.0, 0.3), "material.E"),
    (lambda: stiffness_isotropic(-1e9, 0.3), "material.E"),
    (lambda: stiffness_isotropic(1e9, 0.5), "material.nu"),
    (lambda: stiffness_isotropic(1e9, -1.0), "material.nu"),
    (lambda: stiffness_isotropic(1e9, 0.7), "material.nu"),
    (lambda: stiffness_orthotropic(**{**WOOD, "E2": 0.0}), "material.E2"),
    (lambda: stiffness_orthotropic(**{**WOOD, "G13": -1.0}), "material.G13"),
    (lambda: stiffness_orthotropic(**{**WOOD, "nu23": 1.5}), "material.nu23"),  # > sqrt(E2/E3)
    (lambda: stiffness_orthotropic(**{**WOOD, "nu12": -4.0}), "material.nu12"),  # |nu12| > sqrt(E1/E2)
    (lambda: stiffness_orthotropic(1e9, 1e9, 1e9, 0.9, 0.9, 0.9, 1e8, 1e8, 1e8), "material.(nu12, nu13, nu23)"),
    (lambda: stiffness_transverse([0, 0, 1], -1.0, 1e9, 0.3, 0.3, 1e8), "material.E_axial"),
    (lambda: stiffness_transverse([0, 0, 1], 1e9, 1e9, 1.0, 0.3, 1e8), "material.nu_transverse"),
    (lambda: stiffness_transverse([0, 0, 1], 1e9, 4e9, 0.3, 0.6, 1e8), "material.nu_axial"),
    (lambda: stiffness_transverse([0, 0, 0], 1e9, 1e9, 0.3, 0.3, 1e8), "material.axis"),
    (lambda: stiffness_full(_asym()), "material.stiffness[0][1]"),
    (lambda: stiffness_full(np.diag([1.0, 1, 1, 1, 1, -1])), "material.stiffness"),
    (lambda: stiffness_full(np.ones((5, 5))), "material.stiffness"),
    (lambda: Material("glass", -1.0, stiffness_isotropic(70e9, 0.2)), "materials.glass.density"),
    (lambda: Material("glass", 2500, stiffness_isotropic(70e9, 0.2), toughness=0.0), "materials.glass.toughness"),
    (lambda: Material("glass", 2500, stiffness_isotropic(70e9, 0.2), restitution=1.5), "materials.glass.restitution"),
]


def _asym() -> np.ndarray:
    C = stiffness_isotropic(1e9, 0.3)
    C[0, 1] *= 1.01
    return C


@pytest.mark.parametrize("make,key", BAD, ids=[k for _, k in BAD])
def test_invalid_material_raises_named_error(make, key):
    with pytest.raises(MaterialError) as err:
        make()
    assert err.value.key_path == key
    assert key.split(".")[-1] in str(err.value)
    assert err.value.allowed  # names the allowed range


def test_valid_bound_case_is_accepted():
    """nu23 = 1.0 > 0.5 is allowed here: |nu23| < sqrt(E2/E3) = 1.34 and the compliance is PD."""
    C = stiffness_orthotropic(**{**WOOD, "nu23": 1.0})
    assert np.linalg.eigvalsh(C)[0] > 0


def test_material_from_dict_and_errors():
    m = material_from_dict({"model": "isotropic", "E": 70e9, "nu": 0.22, "density": 2500, "toughness": 8.0},
                           key="materials.glass")
    assert m.name == "glass" and m.toughness == 8.0
    with pytest.raises(MaterialError) as err:
        material_from_dict({"model": "isotropic", "E": 70e9, "density": 2500}, key="materials.glass")
    assert err.value.key_path == "materials.glass.nu"
    with pytest.raises(MaterialError) as err:
        material_from_dict({"model": "isotropic", "E": 70e9, "nu": 0.2, "Ee": 1, "density": 1}, key="m")
    assert err.value.key_path == "m.Ee"


def test_wave_speed():
    E, nu, rho = 100e6, 0.3, 1000.0
    m = Material("beam", rho, stiffness_isotropic(E, nu))
    cp = math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    assert wave_speed_max(m) == pytest.approx(cp, rel=1e-9)
    # transversely isotropic, stiff axis along (1,1,1): the fastest wave runs along the axis
    axis = np.ones(3) / math.sqrt(3)
    C = stiffness_transverse(axis, 20e9, 1e9, 0.2, 0.2, 0.5e9)
    Q = np.linalg.qr(np.column_stack([axis, [1, 0, 0], [0, 1, 0]]))[0]
    c33 = rotate_stiffness(C, Q.T)[0, 0]  # C in the frame of Q (first column of Q = +-axis): C_axis,axis
    assert p_wave_modulus_max(C) == pytest.approx(c33, rel=1e-8)
    assert p_wave_modulus_max(C) <= 2 * np.linalg.eigvalsh(C)[-1]
