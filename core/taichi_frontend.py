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

More work left out on the same principle, the same results (the first two measured on `main.py run
pot --frames 20`, 78 kernels, 3.6 s of frontend before them; the others in docs/decisions.md, session 24):
- `get_pos_info` itself (the excerpt text of one AST node) is memoised by everything it reads: the
  file, the line offset and indent of the function's source, the function's name, the node's kind and
  span, and the source lines the span covers. A ti.func is transformed again for every kernel that
  calls it, so the same excerpts are formatted hundreds of times.
- `getsourcefile` / `getsourcelines` of a kernel or ti.func (what `_get_tree_and_ctx` parses) are
  memoised per function object: `inspect` re-tokenises the whole module and stats the file on every
  call. A function object's source does not change while it lives (an edited file gives new function
  objects when it is re-imported).
- The excerpt of the node being built is pushed on the runtime's source-info stack for every node the
  transformer visits (58k for the pot's first frame), but read (`get_current_src_info`, into a
  `DebugInfo`) for about one in seventeen. `Builder.__call__` now pushes a `PendingExcerpt` (the
  context and the node) and `get_current_src_info` formats it when read: the same text, from the
  same memo, only where it is used; an error still formats its excerpt at once (the same code as
  Taichi's). `_get_tree_and_ctx` re-wraps every source line of a ti.func (`textwrap.fill`, width
  9999) each time a kernel inlines it: `kernel_impl.textwrap` is given a `fill` and `dedent`
  memoised by their arguments (the same strings).
- Taichi's small-matrix operations (`@`, `cross`, `dot`, `norm`, ...) are built straight into the IR
  instead of inlined as `ti.func`s (core/taichi_matrix.py; 40% of the nodes before).
- Every field Taichi creates keeps the text of the stack that created it (`impl.get_traceback`, for
  an error about an unplaced field); `_stack_text` formats the same text without `extract_stack`'s
  stat of every file on the stack.
- `_inside_class` (is `@ti.kernel` decorating a method?) reads the decorator's source line with
  `inspect.getframeinfo`, which resolves the module and its whole source for every kernel defined
  (0.4 s for the pot's modules); the same line comes from `linecache` directly. `install()` swaps it
  for the kernels defined after it; `install_before_import()`, called before Taichi is first imported,
  swaps it as soon as Taichi's kernel module is loaded, so that the 80-odd kernels and functions
  Taichi defines in its own package while `import taichi` runs gain too (that import 0.41-0.50 s ->
  0.30-0.37 s here, in both the simulation's and the drawing process's start).

Single-thread runs (`install_serial_loops`, called by `core.runtime.init_taichi` for the CPU with one
thread): Taichi's CPU backend hands every offloaded parallel loop to its thread pool and the launching
thread sleeps on a condition variable until the pool is done, even with `cpu_max_num_threads=1`:
on this 2-core machine 18 us for a kernel without a loop, 99 us with one and 351 us with five
(bench/bench_launch.py). A rigid step is some 20 kernels of 2-8 loops each, launched 4 times a
frame: a falling pot's frame took 29 ms, 8 ms with the hook. The hook builds every range loop
(`range`, `ti.ndrange`, `ti.grouped(ti.ndrange)`) that no non-static loop encloses as
`ti.loop_config(serialize=True)` would: the same iterations in the same order on the launching
thread. Struct-for loops are left alone (Taichi cannot serialise them). Results can differ from the
pooled build in the last bit only where a loop reduces into a local that was not zero before it
(Taichi's thread-local reduction adds the loop's partial sum to it at the end); each build is
bitwise reproducible.
"""

from __future__ import annotations

import ast
import functools
import linecache
import sys
import textwrap
import traceback

from core import taichi_matrix

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


def _memo_pos_info(get_pos_info):
    """`ASTTransformerContext.get_pos_info` memoised by every input it reads."""
    memo: dict = {}

    def pos_info(ctx, node):
        first, last = node.lineno, getattr(node, "end_lineno", node.lineno)
        body = getattr(node, "body", None)
        key = (ctx.file, ctx.lineno_offset, ctx.indent, ctx.func.func.__name__, type(node).__name__, first, last,
               node.col_offset, getattr(node, "end_col_offset", None),
               body[0].lineno if isinstance(body, list) and body else None, tuple(ctx.src[first - 1:last]))
        text = memo.get(key)
        if text is None:
            text = memo[key] = get_pos_info(ctx, node)
        return text

    pos_info.memoised = True
    pos_info.original = get_pos_info
    return pos_info


def _memo_per_function(lookup):
    """`getsourcefile` / `getsourcelines` memoised per function object (lists are copied out)."""
    memo: dict = {}

    def cached(obj):
        try:
            hit = memo.get(obj)
        except TypeError:  # unhashable: not a plain function
            return lookup(obj)
        if hit is None:
            hit = memo[obj] = lookup(obj)
        if isinstance(hit, tuple) and hit and isinstance(hit[0], list):
            return list(hit[0]), hit[1]
        return hit

    cached.memoised = True
    cached.original = lookup
    return cached


def _inside_class_fast(patterns):
    """Taichi's `_inside_class(level)`: whether the statement at that caller frame starts a class
    (or `@ti.data_oriented`), its source line read from linecache instead of inspect.getframeinfo."""

    def inside_class(level_of_class_stackframe):
        try:
            frame = sys._getframe(level_of_class_stackframe)
            line = linecache.getline(frame.f_code.co_filename, frame.f_lineno).strip()
        except ValueError:  # the stack is not that deep
            return False
        return any(p.match(line) for p in patterns)

    inside_class.memoised = True
    return inside_class


class PendingExcerpt:
    """The source excerpt of an AST node, formatted when first read (module doc)."""

    __slots__ = ("ctx", "node", "text")

    def __init__(self, ctx, node) -> None:
        self.ctx, self.node, self.text = ctx, node, None

    def __str__(self) -> str:
        if self.text is None:
            self.text = self.ctx.get_pos_info(self.node)
        return self.text


def _lazy_dispatch(builder_call):
    """Taichi 1.7.4's `Builder.__call__` (ast_transformer_utils.py), with the node's excerpt pushed as a
    PendingExcerpt instead of formatted; the error path is Taichi's, line for line."""
    from taichi.lang import impl
    from taichi.lang.ast.ast_transformer_utils import TaichiSyntaxError
    from taichi.lang.exception import TaichiCompilationError, handle_exception_from_cpp

    def call(self, ctx, node):
        method = getattr(self, "build_" + node.__class__.__name__, None)
        try:
            if method is None:
                error_msg = f'Unsupported node "{node.__class__.__name__}"'
                raise TaichiSyntaxError(error_msg)
            info = PendingExcerpt(ctx, node) if isinstance(node, (ast.stmt, ast.expr)) else ""
            with impl.get_runtime().src_info_guard(info):
                return method(ctx, node)
        except Exception as e:
            if impl.get_runtime().print_full_traceback:
                raise e
            if ctx.raised or not isinstance(node, (ast.stmt, ast.expr)):
                raise e.with_traceback(None)  # noqa: B904 (Taichi's code: the context stays)
            ctx.raised = True
            e = handle_exception_from_cpp(e)
            if not isinstance(e, TaichiCompilationError):
                msg = ctx.get_pos_info(node) + traceback.format_exc()
                raise TaichiCompilationError(msg) from None
            msg = ctx.get_pos_info(node) + str(e)
            raise type(e)(msg) from None

    call.lazy = True
    call.original = builder_call
    return call


def _read_excerpt(get_current_src_info):
    def current(runtime):
        return str(get_current_src_info(runtime))

    current.lazy = True
    current.original = get_current_src_info
    return current


def _stack_text(stacklevel: int = 1) -> str:
    """`taichi.lang.util.get_traceback`: the text of the stack above the caller's `stacklevel` frames,
    as `traceback.format_list(traceback.extract_stack()[: -1 - stacklevel])` gives it, without
    `extract_stack`'s `linecache.checkcache` (a stat of every file on the stack) per call. Taichi keeps
    it with every field it creates (480 at the pot's start, 63 ms), for an error it rarely raises."""
    frame = sys._getframe(1)
    for _ in range(stacklevel):
        frame = frame.f_back if frame is not None else None
    frames = []
    while frame is not None:
        code = frame.f_code
        frames.append(traceback.FrameSummary(code.co_filename, frame.f_lineno, code.co_name, lookup_line=False))
        frame = frame.f_back
    return "".join(traceback.format_list(frames[::-1]))


class _MemoTextwrap:
    """What `kernel_impl` uses of the textwrap module, `fill` and `dedent` memoised by their arguments."""

    fill = staticmethod(functools.lru_cache(maxsize=WRAP_MEMO_SIZE)(textwrap.fill))
    dedent = staticmethod(functools.lru_cache(maxsize=1024)(textwrap.dedent))

    def __getattr__(self, name):
        return getattr(textwrap, name)


class _PatchOnLoad:
    """An import finder that hands Taichi's kernel module to `_patch_inside_class` right after it
    has run (`install_before_import`); it finds no module itself and takes itself out of the path."""

    MODULE = "taichi.lang.kernel_impl"

    def find_spec(self, name, path, target=None):
        if name != self.MODULE:
            return None
        sys.meta_path.remove(self)
        from importlib.machinery import PathFinder

        spec = PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            _patch_inside_class(module)

        spec.loader.exec_module = exec_module
        return spec


def _patch_inside_class(kernel_impl) -> None:
    if not getattr(kernel_impl._inside_class, "memoised", False):
        kernel_impl._inside_class = _inside_class_fast(kernel_impl._KERNEL_CLASS_STACKFRAME_STMT_RES)


def install_before_import() -> bool:
    """Before Taichi's first import: its kernel module gets the linecache `_inside_class` as soon as it
    is loaded (module doc). False (nothing done) where Taichi is imported already or a finder is
    waiting for it."""
    if "taichi" in sys.modules or any(isinstance(f, _PatchOnLoad) for f in sys.meta_path):
        return False
    sys.meta_path.insert(0, _PatchOnLoad())
    return True


def install() -> None:
    """Swap in the memoised TextWrapper, get_pos_info and source lookups, the excerpts formatted when
    read, the direct matrix operations and the cheaper stack text (module doc; idempotent)."""
    from taichi.lang import impl, kernel_impl
    from taichi.lang.ast import ast_transformer_utils

    if getattr(ast_transformer_utils, "TextWrapper", None) is not MemoTextWrapper:
        ast_transformer_utils.TextWrapper = MemoTextWrapper
    context = ast_transformer_utils.ASTTransformerContext
    if not getattr(context.get_pos_info, "memoised", False):
        context.get_pos_info = _memo_pos_info(context.get_pos_info)
    _patch_inside_class(kernel_impl)
    if not getattr(ast_transformer_utils.Builder.__call__, "lazy", False):
        ast_transformer_utils.Builder.__call__ = _lazy_dispatch(ast_transformer_utils.Builder.__call__)
        impl.PyTaichi.get_current_src_info = _read_excerpt(impl.PyTaichi.get_current_src_info)
    if not isinstance(kernel_impl.textwrap, _MemoTextwrap):
        kernel_impl.textwrap = _MemoTextwrap()
    taichi_matrix.install()
    if impl.get_traceback is not _stack_text:
        impl.get_traceback = _stack_text
    for name in ("getsourcefile", "getsourcelines"):
        if not getattr(getattr(kernel_impl, name), "memoised", False):
            setattr(kernel_impl, name, _memo_per_function(getattr(kernel_impl, name)))


def _is_range_loop(transformer, ctx, node) -> bool:
    """Whether a `for` statement builds a range loop (Taichi's build_For dispatch), not a struct-for."""
    iterator = node.iter
    decorator = transformer.get_decorator(ctx, iterator)
    if decorator == "ndrange":
        return True
    if decorator == "grouped":
        return len(iterator.args) == 1 and transformer.get_decorator(ctx, iterator.args[0]) == "ndrange"
    return decorator == "" and isinstance(iterator, ast.Call) and isinstance(iterator.func, ast.Name) \
        and iterator.func.id == "range"


def install_serial_loops() -> None:
    """Build every outermost range loop serial (module doc, single-thread runs); idempotent. Only
    kernels compiled afterwards change (Taichi's offline cache keys the loop's setting)."""
    from taichi.lang.ast import ast_transformer

    transformer = ast_transformer.ASTTransformer
    build_for = transformer.build_For
    if getattr(build_for, "serial_loops", False):
        return

    def build_serial_for(ctx, node):
        outermost = not any(not scope.is_static for scope in ctx.loop_scopes)
        if outermost and _is_range_loop(transformer, ctx, node):
            ctx.ast_builder.parallelize(1)
            ctx.ast_builder.strictly_serialize()
        return build_for(ctx, node)

    build_serial_for.serial_loops = True
    transformer.build_For = staticmethod(build_serial_for)


__all__ = ["MemoTextWrapper", "PendingExcerpt", "install", "install_serial_loops"]
