"""Start-up (core/taichi_frontend.py, core/runtime.py): the memoised TextWrapper, source excerpts and
source lookups, the excerpts formatted when read and a field's stack text give Taichi's frontend
exactly what the standard ones give, so a kernel's compile error and warning read the same and a
method kernel is still told from a plain one, and init_taichi installs them (Taichi's own kernels,
defined while it is imported, too); the offline kernel cache is large enough not to evict."""

import functools
import inspect
import textwrap
import time

import numpy as np
import pytest
import taichi as ti
from taichi.lang import kernel_impl
from taichi.lang.ast import ast_transformer_utils

from core.taichi_frontend import MemoTextWrapper

SAMPLES = [
    "",
    "    x = a + b",
    "\tif i < n:\t# a tab",
    "        " + "^" * 12,
    "        total += weights[i] * values[i, j] + offsets[j] - corrections[i, j] * scale_factor_for_the_run",
    " " * 90 + "^^^",
    "a" * 200,
    "  trailing spaces   ",
]


@pytest.mark.parametrize("text", SAMPLES)
def test_memoised_wrap_equals_the_standard_one(text):
    assert MemoTextWrapper(width=80).wrap(text) == textwrap.TextWrapper(width=80).wrap(text)
    assert MemoTextWrapper(width=80).wrap(text) == textwrap.TextWrapper(width=80).wrap(text)  # from the memo
    # any option besides the width takes the standard path
    assert MemoTextWrapper(width=30, drop_whitespace=False).wrap(text) == textwrap.TextWrapper(
        width=30, drop_whitespace=False).wrap(text)
    # the source lines of a kernel or ti.func (kernel_impl._get_tree_and_ctx)
    assert isinstance(kernel_impl.textwrap.fill, functools._lru_cache_wrapper)
    assert kernel_impl.textwrap.fill(text, tabsize=4, width=9999) == textwrap.fill(text, tabsize=4, width=9999)
    assert kernel_impl.textwrap.dedent(text) == textwrap.dedent(text)


def test_installed_by_init_taichi():
    assert ast_transformer_utils.TextWrapper is MemoTextWrapper


# A fresh process: how often Taichi's `import` reads a decorator's line through inspect, with and without
# the finder that `init_taichi` puts in place first (core.taichi_frontend.install_before_import).
_IMPORT_CHILD = """
import inspect, sys
from core.taichi_frontend import _PatchOnLoad, install_before_import  # imports no Taichi
calls = []
original = inspect.getframeinfo
inspect.getframeinfo = lambda *a, **k: calls.append(1) or original(*a, **k)
if sys.argv[1] == "hook":
    assert install_before_import() and not install_before_import()  # one finder at a time
import taichi
from taichi.lang import kernel_impl
assert not any(isinstance(f, _PatchOnLoad) for f in sys.meta_path)  # it took itself out
assert not install_before_import()  # Taichi is imported: nothing to do
print(len(calls), getattr(kernel_impl._inside_class, "memoised", False))
"""


def test_taichis_own_kernels_are_defined_without_inspect_when_hooked_before_import():
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]

    def child(mode: str) -> list[str]:
        run = subprocess.run([sys.executable, "-c", _IMPORT_CHILD, mode], cwd=root, capture_output=True, text=True,
                             timeout=120, check=True)
        return run.stdout.splitlines()[-1].split()  # after Taichi's banner

    assert child("hook") == ["0", "True"]
    calls, memoised = child("plain")
    assert int(calls) > 20 and memoised == "False"  # what the finder spares: Taichi reads each one's line


def _compile_error(monkeypatch, wrapper, pos_info) -> str:
    monkeypatch.setattr(ast_transformer_utils, "TextWrapper", wrapper)
    monkeypatch.setattr(ast_transformer_utils.ASTTransformerContext, "get_pos_info", pos_info)

    @ti.kernel
    def broken():
        x = undefined_name_for_the_test * 2.0  # noqa: F821, F841

    with pytest.raises(ti.TaichiCompilationError) as err:
        broken()
    return str(err.value).replace("broken", "")


def test_a_compile_error_reads_the_same(monkeypatch):
    installed = ast_transformer_utils.ASTTransformerContext.get_pos_info
    assert installed.memoised
    memo = _compile_error(monkeypatch, MemoTextWrapper, installed)
    again = _compile_error(monkeypatch, MemoTextWrapper, installed)  # from the memo
    plain = _compile_error(monkeypatch, textwrap.TextWrapper, installed.original)
    assert "undefined_name_for_the_test" in memo and "^" in memo
    assert memo.splitlines()[1:] == plain.splitlines()[1:] == again.splitlines()[1:]  # line 0: file and line


def _lossy_assign_warning(capfd) -> str:
    """The warning Taichi's compiler prints for an f64 value stored in an f32 field, with the source
    excerpt the IR holds for that statement (a DebugInfo made from `get_current_src_info`)."""
    target = ti.field(ti.f32, shape=1)
    scale = float(time.time_ns() % 1000003) + 0.5  # a kernel no cache holds: the compiler runs and warns

    @ti.kernel
    def lossy(x: ti.f64):
        target[0] = x * scale

    capfd.readouterr()
    lossy(1.0)
    captured = capfd.readouterr()
    text = captured.out + captured.err
    return text[text.index(", File "):]  # after "While compiling `lossy_c<n>`"


def test_excerpts_formatted_when_read_are_the_eager_ones(monkeypatch, capfd):
    from taichi.lang import impl

    lazy_call = ast_transformer_utils.Builder.__call__
    assert lazy_call.lazy and impl.PyTaichi.get_current_src_info.lazy
    lazy = _lossy_assign_warning(capfd)
    monkeypatch.setattr(ast_transformer_utils.Builder, "__call__", lazy_call.original)
    monkeypatch.setattr(impl.PyTaichi, "get_current_src_info", impl.PyTaichi.get_current_src_info.original)
    eager = _lossy_assign_warning(capfd)
    assert "target[0] = x * scale" in lazy and "^" in lazy and "lose precision" in lazy
    assert lazy == eager


def test_a_fields_stack_text_is_taichis():
    """Taichi keeps the creating stack's text with every field (`impl.get_traceback`); the installed
    one gives Taichi's text (`util.get_traceback`) at every level, here under pytest's deep stack."""
    from taichi.lang import impl, util

    def nested(level):
        return impl.get_traceback(level), util.get_traceback(level)

    assert impl.get_traceback is not util.get_traceback
    for level in (1, 2, 4, 10_000):
        ours, taichis = nested(level)
        assert ours == taichis
    assert "test_taichi_frontend.py" in nested(1)[0] and "nested(1)" in nested(1)[0]


def test_memoised_source_lookups_equal_inspect_and_are_copies():
    lines, start = kernel_impl.getsourcelines(_compile_error)
    assert kernel_impl.getsourcelines.memoised and kernel_impl.getsourcefile.memoised
    assert (lines, start) == kernel_impl.getsourcelines.original(_compile_error) == inspect.getsourcelines(
        _compile_error)
    assert kernel_impl.getsourcefile(_compile_error) == inspect.getsourcefile(_compile_error)
    lines.append("changed by a caller")
    assert kernel_impl.getsourcelines(_compile_error)[0] == inspect.getsourcelines(_compile_error)[0]


def test_a_method_kernel_is_still_told_from_a_plain_one():
    assert kernel_impl._inside_class.memoised

    @ti.data_oriented
    class Scaled:
        def __init__(self):
            self.value = ti.field(ti.f64, shape=())

        @ti.kernel
        def fill(self, v: ti.f64):
            self.value[None] = 2.0 * v

    s = Scaled()
    s.fill(1.5)  # a method kernel taken for a plain one would not bind self
    assert s.value[None] == 3.0

    @ti.kernel
    def plain() -> ti.f64:
        return 1.0

    assert plain() == 1.0


def test_the_offline_cache_is_large_enough_not_to_evict():
    """Taichi's default cache (100 MB, LRU) evicted kernels once the suite and a few scenes had run."""
    from taichi.lang import impl

    from core.runtime import OFFLINE_CACHE_MAX_BYTES

    cfg = impl.current_cfg()
    assert cfg.offline_cache and cfg.offline_cache_max_size_of_files == OFFLINE_CACHE_MAX_BYTES >= 500 * 2**20


def test_single_thread_runs_build_their_outermost_range_loops_serial():
    """Taichi refuses `break` in an outermost loop it runs through its thread pool ("Cannot break in
    the outermost loop"); with one CPU thread init_taichi builds those loops serial, so a kernel that
    stops at the first match compiles and finds it. ndrange, grouped ndrange, a loop in a ti.func and
    a struct-for (left to the pool) give what numpy gives. On CUDA or with several CPU threads the
    hook is not installed: Taichi's loops stay parallel there."""
    from taichi.lang.ast import ast_transformer

    from core.runtime import ensure_runtime

    info = ensure_runtime()
    installed = getattr(ast_transformer.ASTTransformer.build_For, "serial_loops", False)
    assert installed == (info.arch == "cpu" and info.threads == 1)
    if not installed:
        return
    values = ti.field(ti.i32, shape=16)
    grid = ti.field(ti.i32, shape=(4, 4))
    values.from_numpy(np.arange(16, dtype=np.int32) ** 2)

    @ti.kernel
    def first_above(limit: ti.i32) -> ti.i32:
        hit = -1
        for i in range(16):
            if values[i] > limit:
                hit = i
                break
        return hit

    @ti.func
    def total_of_values() -> ti.i32:
        total = 0
        for i in range(16):
            total += values[i]
        return total

    @ti.kernel
    def fill_and_sum() -> ti.i32:
        for i, j in ti.ndrange(4, 4):
            grid[i, j] = i * 4 + j
        for ij in ti.grouped(ti.ndrange(4, 4)):
            grid[ij] += 1
        for i, j in grid:  # struct-for
            grid[i, j] *= 2
        return total_of_values()

    assert first_above(50) == 8 and first_above(1000) == -1
    assert fill_and_sum() == int((np.arange(16) ** 2).sum())
    np.testing.assert_array_equal(grid.to_numpy(), 2 * (np.arange(16).reshape(4, 4) + 1))
