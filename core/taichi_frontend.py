"""A faster start for Taichi 1.7.4's Python frontend (issue 16: start to first frame).

Taichi's offline cache skips the LLVM compile of a kernel it has seen, but every process still runs
the Python frontend (the AST transformer) on every kernel it launches. That frontend formats a
source excerpt for each AST node it visits, for error messages it will probably never raise
(`ASTTransformerContext.get_pos_info`), and wraps both the source line and its caret line with a
fresh `textwrap.TextWrapper(width=80)` each time: 125k wraps for the pot scene's 47 kernels, about
40% of the frontend and 1.5-2 s of a warm start on this 2-core machine (cProfile of
`main.py run pot --frames 1`).

`install()` gives that module a TextWrapper whose `wrap` is memoised by (width, text). It is used
only with `width=80` and returns exactly what the standard one returns (a wrapper built with any
other option falls back to the standard code), so the error messages are unchanged
(tests/unit/test_taichi_frontend.py compares them). Called once by `core.runtime.init_taichi`.
"""

from __future__ import annotations

import functools
import textwrap

WRAP_MEMO_SIZE = 1 << 16  # distinct (width, line) pairs kept: a few MB at most


@functools.lru_cache(maxsize=WRAP_MEMO_SIZE)
def _wrapped(width: int, text: str) -> tuple[str, ...]:
    return tuple(textwrap.TextWrapper(width=width).wrap(text))


class MemoTextWrapper(textwrap.TextWrapper):
    """textwrap.TextWrapper whose `wrap` is memoised when only `width` was given."""

    def __init__(self, width: int = 70, **options) -> None:
        super().__init__(width=width, **options)
        self._plain = not options

    def wrap(self, text: str) -> list[str]:
        if self._plain:
            return list(_wrapped(self.width, text))
        return super().wrap(text)


def install() -> None:
    """Swap the TextWrapper Taichi's AST transformer uses for the memoised one (idempotent)."""
    from taichi.lang.ast import ast_transformer_utils

    if getattr(ast_transformer_utils, "TextWrapper", None) is not MemoTextWrapper:
        ast_transformer_utils.TextWrapper = MemoTextWrapper


__all__ = ["MemoTextWrapper", "install"]
