"""sph.eigen: principal values/directions of symmetric 3x3 tensors (Taichi and numpy twin).

Cases named in TAICHI_NOTES (where ti.sym_eig fails): [[5,0,0],[0,2,1],[0,1,2]], diagonal input,
repeated eigenvalues (identity, diag(2,2,5)), plus random symmetric matrices against numpy.linalg.eigh.
"""

import numpy as np
import pytest

from sph.eigen import sym_eig3_batch, sym_eig3_np

CASES = {
    "block": (np.array([[5.0, 0, 0], [0, 2, 1], [0, 1, 2]]), [5.0, 3.0, 1.0]),
    "diagonal": (np.diag([1.0, -3.0, 2.0]), [2.0, 1.0, -3.0]),
    "identity": (np.eye(3), [1.0, 1.0, 1.0]),
    "repeated": (np.diag([2.0, 2.0, 5.0]), [5.0, 2.0, 2.0]),
    "zero": (np.zeros((3, 3)), [0.0, 0.0, 0.0]),
    "large_isotropic": (1e6 * np.eye(3) + np.array([[1.0, 0.5, 0], [0.5, 0, 0], [0, 0, -1.0]]), None),
}


def _check(A: np.ndarray, vals: np.ndarray, V: np.ndarray, tol: float) -> None:
    scale = max(np.abs(A).max(), 1e-300)
    ref = np.linalg.eigvalsh(A)[::-1]
    assert np.all(np.diff(vals) <= tol * scale), "eigenvalues must be sorted descending"
    np.testing.assert_allclose(vals, ref, rtol=0, atol=tol * scale)
    np.testing.assert_allclose(V.T @ V, np.eye(3), rtol=0, atol=tol)  # orthonormal
    assert np.linalg.det(V) == pytest.approx(1.0, abs=tol)  # right-handed
    np.testing.assert_allclose(A @ V, V * vals, rtol=0, atol=tol * scale)  # A v = lambda v


@pytest.mark.parametrize("name", list(CASES))
def test_named_cases_taichi_and_numpy(name, taichi_runtime):
    A, expected = CASES[name]
    tol = 1e-12
    vals, vecs = sym_eig3_batch(A[None])
    _check(A, vals[0], vecs[0], tol)
    v_np, V_np = sym_eig3_np(A)
    _check(A, v_np, V_np, tol)
    if expected is not None:
        np.testing.assert_allclose(vals[0], expected, atol=1e-13)
    if name == "block":  # the eigenvector of 5 is e_x, of 3 is (0,1,1)/sqrt2, of 1 is (0,1,-1)/sqrt2
        assert abs(vecs[0][:, 0] @ [1, 0, 0]) == pytest.approx(1.0, abs=1e-13)
        assert abs(vecs[0][:, 1] @ np.array([0, 1, 1]) / np.sqrt(2)) == pytest.approx(1.0, abs=1e-13)


def test_random_symmetric_against_eigh(taichi_runtime):
    rng = np.random.default_rng(7)
    n = 400
    M = rng.standard_normal((n, 3, 3)) * 10.0 ** rng.uniform(-6, 6, (n, 1, 1))
    A = 0.5 * (M + M.transpose(0, 2, 1))
    # also nearly repeated eigenvalues: Q diag(1, 1 + 1e-9, -2) Q^T
    Q, _ = np.linalg.qr(rng.standard_normal((50, 3, 3)))
    A = np.concatenate([A, Q @ np.diag([1.0, 1.0 + 1e-9, -2.0]) @ Q.transpose(0, 2, 1)])
    vals, vecs = sym_eig3_batch(A)
    v_np, V_np = sym_eig3_np(A)
    for k in range(A.shape[0]):
        _check(A[k], vals[k], vecs[k], 1e-12)
        _check(A[k], v_np[k], V_np[k], 1e-12)
