"""Start-up (core/taichi_frontend.py, core/runtime.py): the memoised TextWrapper gives Taichi's
frontend exactly the text the standard one gives, so a kernel's compile error reads the same, and
init_taichi installs it; the offline kernel cache is large enough not to evict."""

from __future__ import annotations

import textwrap

import pytest
import taichi as ti
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


def test_installed_by_init_taichi():
    assert ast_transformer_utils.TextWrapper is MemoTextWrapper


def _compile_error(monkeypatch, wrapper) -> str:
    monkeypatch.setattr(ast_transformer_utils, "TextWrapper", wrapper)

    @ti.kernel
    def broken():
        x = undefined_name_for_the_test * 2.0  # noqa: F821, F841

    with pytest.raises(ti.TaichiCompilationError) as err:
        broken()
    return str(err.value).replace("broken", "")


def test_a_compile_error_reads_the_same(monkeypatch):
    memo = _compile_error(monkeypatch, MemoTextWrapper)
    plain = _compile_error(monkeypatch, textwrap.TextWrapper)
    assert "undefined_name_for_the_test" in memo and "^" in memo
    assert memo.splitlines()[1:] == plain.splitlines()[1:]  # line 0 names the file and line number


def test_the_offline_cache_is_large_enough_not_to_evict():
    """Taichi's default cache (100 MB, LRU) evicted kernels once the suite and a few scenes had run."""
    from taichi.lang import impl

    from core.runtime import OFFLINE_CACHE_MAX_BYTES

    cfg = impl.current_cfg()
    assert cfg.offline_cache and cfg.offline_cache_max_size_of_files == OFFLINE_CACHE_MAX_BYTES >= 500 * 2**20
