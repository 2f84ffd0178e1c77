"""The short launch path (core/taichi_launch.py): a kernel's later calls skip Taichi's per-argument lookup
and give what Taichi's own path gives, bit for bit, for every argument kind the project passes (scalars,
numpy arrays, vector ndarrays, Taichi ndarrays, fields, data-oriented objects and values as templates,
return values); a new signature compiles its own instance; the rest, and every error, is Taichi's own path.
No `from __future__ import annotations` here: Taichi reads the kernels' annotations as objects."""

import gc

import numpy as np
import pytest
import taichi as ti
from taichi.lang import kernel_impl

vec3 = ti.types.vector(3, float)


@ti.data_oriented
class Holder:
    def __init__(self, n: int) -> None:
        self.value = ti.field(float, shape=n)  # (n,) -: what the kernel writes


@ti.kernel
def k_mix(h: ti.template(), doubled: ti.template(), n: ti.i32, scale: float, xs: ti.types.ndarray(),
          ids: ti.types.ndarray(), pts: ti.types.ndarray(dtype=vec3, ndim=1), out: ti.types.ndarray()) -> ti.i32:
    count = 0
    for i in range(n):
        v = scale * xs[i] + pts[i].dot(vec3(1.0, 2.0, 3.0)) + ids[i]
        if ti.static(doubled):
            v *= 2.0
        h.value[i] = v
        out[i] = ti.sqrt(v * v + 1.0)
        count += 1
    return count


@ti.kernel
def k_total(a: ti.types.ndarray()) -> float:
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i]
    return s


def _taichis_path(kernel, *args):
    """The same call through Taichi's own `Kernel.__call__`, as install() found it."""
    return kernel_impl.Kernel._taichi_call(kernel._primal, *args)


def _inputs(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.normal(size=n), rng.integers(0, 9, n).astype(np.int32), rng.normal(size=(n, 3)), np.zeros(n)


def test_installed_by_init_taichi():
    assert kernel_impl.Kernel._short_launch


@pytest.mark.parametrize("doubled", [False, True])
def test_the_same_bits_as_taichis_path(doubled):
    h_fast, h_ref = Holder(16), Holder(16)
    for seed in range(3):  # the first call finds the instance, the later ones take the short path
        xs, ids, pts, out = _inputs(16, seed)
        out_ref = out.copy()
        got = k_mix(h_fast, doubled, 16, 0.75, xs, ids, pts, out)
        want = _taichis_path(k_mix, h_ref, doubled, 16, 0.75, xs, ids, pts, out_ref)
        assert got == want == 16
        assert np.array_equal(out, out_ref)
        assert np.array_equal(h_fast.value.to_numpy(), h_ref.value.to_numpy())
    ti_x = ti.ndarray(float, shape=5)
    ti_x.from_numpy(np.arange(5.0))
    assert k_total(ti_x) == _taichis_path(k_total, ti_x) == k_total(np.arange(5.0)) == 10.0


def test_later_calls_skip_taichis_lookup(monkeypatch):
    xs, ids, pts, out = _inputs(8, 7)
    h = Holder(8)
    k_mix(h, False, 8, 1.0, xs, ids, pts, out)  # found
    lookups = []
    original = kernel_impl.Kernel.ensure_compiled
    monkeypatch.setattr(kernel_impl.Kernel, "ensure_compiled", lambda self, *a: lookups.append(1) or original(self, *a))
    k_mix(h, False, 8, 2.0, xs, ids, pts, out)
    assert lookups == []
    k_mix(h, False, 8, 2.0, xs.astype(np.float32), ids, pts, out)  # another dtype: Taichi's lookup, its own instance
    assert lookups == [1]


def test_each_object_gets_its_own_instance_even_at_a_reused_address():
    xs, ids, pts, out = _inputs(4, 3)
    first = Holder(4)
    k_mix(first, False, 4, 1.0, xs, ids, pts, out)
    k_mix(first, False, 4, 1.0, xs, ids, pts, out)
    gone = id(first)
    del first
    gc.collect()
    for _ in range(50):  # a new object, perhaps where the old one lived: it must get its own field written
        h = Holder(4)
        k_mix(h, False, 4, 1.0, xs, ids, pts, out)
        assert np.allclose(h.value.to_numpy(), xs + pts @ np.array([1.0, 2.0, 3.0]) + ids, rtol=1e-12, atol=1e-12)
        if id(h) == gone:
            break


def test_errors_are_taichis():
    xs, ids, pts, out = _inputs(4, 5)
    h = Holder(4)
    k_mix(h, False, 4, 1.0, xs, ids, pts, out)
    with pytest.raises(ti.TaichiRuntimeTypeError):
        k_mix(h, False, 4.5, 1.0, xs, ids, pts, out)  # a float for an i32
    with pytest.raises(ValueError, match="Non contiguous"):
        k_mix(h, False, 4, 1.0, np.zeros(8)[::2], ids, pts, out)
    with pytest.raises(ValueError, match="dimensions"):
        k_mix(h, False, 4, 1.0, xs, ids, pts.ravel(), out)


def test_a_fortran_array_is_copied_back_as_taichi_does():
    @ti.kernel
    def k_fill(a: ti.types.ndarray()):
        for i, j in ti.ndrange(a.shape[0], a.shape[1]):
            a[i, j] = i * 10 + j

    for _ in range(2):
        a = np.asfortranarray(np.zeros((3, 4)))
        k_fill(a)
        assert np.array_equal(a, np.add.outer(10 * np.arange(3.0), np.arange(4.0)))


def test_keywords_take_taichis_path():
    xs, ids, pts, out = _inputs(4, 9)
    h = Holder(4)
    assert k_mix(h, False, 4, 1.0, xs, ids, pts, out=out) == 4
    assert k_mix(h, False, 4, 1.0, xs, ids, pts, out=out) == 4


# A fresh process: Taichi forgets every kernel's compiled instances when a field tree is destroyed; the
# short path must then find the instance again rather than launch the forgotten one.
_DESTROY_CHILD = """
import numpy as np
from core.runtime import init_taichi
init_taichi(precision="f64")
import taichi as ti
from taichi.lang import kernel_impl
target = ti.field(float, shape=4)

@ti.kernel
def k_add(x: ti.types.ndarray(), s: float):
    for i in range(4):
        target[i] += x[i] * s

x = np.arange(4.0)
k_add(x, 1.0)
k_add(x, 1.0)  # the short path
fb = ti.FieldsBuilder()
other = ti.field(float)
fb.dense(ti.i, 4).place(other)
tree = fb.finalize()
other[0] = 1.0  # a tree never touched must not be destroyed (docs/decisions.md, Taichi facts)
tree.destroy()
assert not k_add._primal.compiled_kernels  # Taichi forgot them
k_add(x, 1.0)
k_add(x, 1.0)
assert kernel_impl.Kernel._short_launch and len(k_add._primal.compiled_kernels) == 1
print(target.to_numpy().tolist())
"""


def test_a_destroyed_field_tree_makes_the_path_find_the_instance_again(tmp_path):
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    child = tmp_path / "destroy_child.py"  # a file: Taichi reads a kernel's source
    child.write_text(_DESTROY_CHILD)
    env = dict(os.environ, PYTHONPATH=str(root))
    run = subprocess.run([sys.executable, str(child)], cwd=root, env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    assert run.stdout.splitlines()[-1] == str([0.0, 4.0, 8.0, 12.0])
