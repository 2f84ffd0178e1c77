"""core/taichi_matrix.py: the small-matrix operations built straight into a kernel give, bit for bit,
what Taichi's own `ti.func`s give (the same kernel compiled both ways, in f32 and f64), installed by
init_taichi; other shapes, errors and Python scope still take Taichi's path."""

import numpy as np
import pytest
import taichi as ti
from taichi.lang import matrix_ops

from core import taichi_matrix

N = 64  # random cases per kernel
OUT = 37  # scalars each case writes (see `run` in `_results`)


def _shape(value) -> tuple:
    return tuple(value.get_shape()) if value.is_tensor() else ()


def _results(dtype):
    """A fresh kernel (compiled at its first call, with whatever matrix_ops holds then) over random
    matrices and vectors of `dtype`, every replaced operation and the ones that fall back."""
    mat3, vec3 = ti.types.matrix(3, 3, dtype), ti.types.vector(3, dtype)
    A, B = ti.field(mat3, shape=N), ti.field(mat3, shape=N)
    u, v = ti.field(vec3, shape=N), ti.field(vec3, shape=N)
    w2 = ti.field(ti.types.vector(2, dtype), shape=N)
    out = ti.field(dtype, shape=(N, OUT))
    rng = np.random.default_rng(7)

    def fill(field, shape):  # mixed magnitudes and signs: fused multiply-adds would show
        values = rng.standard_normal((N,) + shape) * 10.0 ** rng.integers(-3, 4, (N,) + shape)
        field.from_numpy(values.astype(np.float32 if dtype == ti.f32 else np.float64))

    fill(A, (3, 3)), fill(B, (3, 3)), fill(u, (3,)), fill(v, (3,)), fill(w2, (2,))

    @ti.func
    def put(i, k: ti.template(), r):  # r's entries at out[i, k:]
        shape = ti.static(_shape(r))
        if ti.static(len(shape) == 0):
            out[i, k] = r
        elif ti.static(len(shape) == 1):
            for j in ti.static(range(shape[0])):
                out[i, k + j] = r[j]
        else:
            for j in ti.static(range(shape[0] * shape[1])):
                out[i, k + j] = r[j // shape[1], j % shape[1]]

    @ti.kernel
    def run():
        for i in range(N):
            put(i, 0, A[i] @ u[i])
            put(i, 3, A[i] @ B[i])
            put(i, 12, u[i].cross(v[i]))
            put(i, 15, u[i].dot(v[i]))
            put(i, 16, A[i].transpose())
            put(i, 25, u[i].norm())
            put(i, 26, u[i].norm_sqr())
            put(i, 27, A[i].sum())
            put(i, 28, u[i] @ A[i])  # a vector on the left: Taichi's path
            put(i, 31, ti.Matrix([[1.0, 2.0, 0.0, 1.0], [3.0, 4.0, 1.0, 0.0]]).transpose() @ w2[i])  # 4x2
            put(i, 35, w2[i].cross(w2[i] * 2.0 + 1.0))  # 2-D: Taichi's path
            put(i, 36, w2[i].norm(1e-3))

    run()
    return out.to_numpy()


def _with_taichi_originals(monkeypatch):
    for name in taichi_matrix.REPLACED:
        monkeypatch.setattr(matrix_ops, name, getattr(matrix_ops, name).original)


def test_installed_by_init_taichi():
    assert all(getattr(getattr(matrix_ops, name), "direct", False) for name in taichi_matrix.REPLACED)


@pytest.mark.parametrize("dtype", [ti.f32, ti.f64])
def test_direct_builds_equal_taichis_bit_for_bit(monkeypatch, dtype):
    direct = _results(dtype)
    with monkeypatch.context() as m:
        _with_taichi_originals(m)
        original = _results(dtype)
    assert np.isfinite(direct).all() and np.abs(direct).max() > 0.0
    assert direct.tobytes() == original.tobytes()


def test_a_shape_error_reads_as_taichis(monkeypatch):
    def message() -> str:
        m3 = ti.field(ti.types.matrix(3, 3, ti.f64), shape=1)
        v4 = ti.field(ti.types.vector(4, ti.f64), shape=1)

        @ti.kernel
        def bad() -> ti.f64:
            return (m3[0] @ v4[0])[0]

        with pytest.raises(ti.TaichiCompilationError) as err:
            bad()
        return str(err.value).splitlines()[-1]

    direct = message()
    with monkeypatch.context() as m:
        _with_taichi_originals(m)
        original = message()
    assert "match" in direct.lower() and direct == original


def test_python_scope_is_taichis():
    a = ti.Matrix([[1.0, 2.0], [3.0, 4.0]])
    b = ti.Vector([1.0, -1.0])
    assert list((a @ b).to_numpy()) == [-1.0, -1.0]
    assert (a.transpose() @ a).to_numpy().tolist() == [[10.0, 14.0], [14.0, 20.0]]
    assert b.dot(b) == 2.0 and b.norm_sqr() == 2.0
