"""A shorter launch path for Taichi 1.7.4 kernels (issue 16: time spent outside the kernels).

Every call of a Taichi kernel runs, in Python, Taichi's template lookup (`extract_arg` for every argument,
then the instance's key) and its argument setter (`recursive_set_args`: a chain of `isinstance` tests per
argument) before the C++ launch. On this 2-core machine that is 18 us for a kernel without arguments,
about 5 us more per scalar and 30 us per numpy array: the rigid substep kernel (a store and 12 scalars)
cost 122 us a call with nothing to do, the particle store's gather (29 arrays) 711 us. A quiet frame of
the pot launches about 70 kernels (four steps of 15, eight of them substeps), so that was about a third of
its 14 ms (not drawn); Pots' first 61 frames launch 7k.

`install()` gives `Kernel.__call__` a path that remembers, per kernel and per *argument signature*, the
compiled instance Taichi's own lookup chose the first time, and then sets the arguments straight on the
launch context. The signature holds everything Taichi's instance key is made of: a template argument
itself (a weak reference for a `@ti.data_oriented` object, as Taichi keys it), and for an ndarray
argument its element type, dimension count and gradient flag; scalars do not enter it. The same
compiled kernel then gets the same arguments through the same C++ setters: results are the same bits.

Whatever this path does not cover takes Taichi's own path, which also compiles and checks: a first call
with a signature, keyword arguments, autodiff, a kernel with `print`, argument kinds other than scalars,
ndarrays and templates (matrices, structs, argument packs, textures), a template that is a tuple, list,
SNode or expression, a scalar of another Python type than Taichi accepts, a numpy array that is not
C-contiguous or has more than 2^31 elements, torch or paddle tensors, an instance Taichi forgot (it
forgets them all when a field tree is destroyed) and a new Taichi program (after `ti.reset`). Errors
therefore read as Taichi's.
"""

from __future__ import annotations

import weakref

import numpy as np

INT32_MAX = 2**31 - 1  # elements beyond which Taichi warns about int32 indexing (its own path does)


class _Slow(Exception):
    """This call takes Taichi's own path."""


class _Plan:
    """The compiled instance a signature maps to, for one Taichi program: valid while the kernel keeps it
    (Taichi forgets every kernel's instances when a field tree is destroyed)."""

    __slots__ = ("prog", "key", "kernel_cpp")

    def __init__(self, prog, key: tuple, kernel_cpp) -> None:
        self.prog = prog
        self.key = key  # the instance's key in the kernel's `compiled_kernels`
        self.kernel_cpp = kernel_cpp


_TEMPLATE_KINDS: dict = {}  # type -> how a template argument of that type enters a signature
_AS_ITSELF, _AS_WEAKREF, _SLOW = 0, 1, 2


def _template_kind(cls: type) -> int:
    """How Taichi's `extract_arg` keys a template argument of type `cls`: by itself, by a weak reference (a
    `@ti.data_oriented` object), or in a way this path leaves to Taichi. Read from the type: an instance's
    attribute lookup goes through data_oriented's `__getattr__` hook (2 us each)."""
    from taichi._lib import core as ti_core
    from taichi.lang import expr, snode
    from taichi.lang._ndarray import Ndarray

    if issubclass(cls, (tuple, list, dict, set, snode.SNode, expr.Expr, ti_core.Expr, Ndarray)):
        return _SLOW
    return _AS_WEAKREF if hasattr(cls, "_data_oriented") else _AS_ITSELF


def _template_key(value):
    """A template argument's part of the signature: what Taichi's `extract_arg` keys it by."""
    cls = type(value)
    kind = _TEMPLATE_KINDS.get(cls)
    if kind is None:
        kind = _TEMPLATE_KINDS[cls] = _template_kind(cls)
    if kind == _AS_ITSELF:
        return value
    if kind == _AS_WEAKREF:
        return weakref.ref(value)
    raise _Slow


def _ndarray_keyer(element_dim: int):
    """An ndarray argument's part of the signature (Taichi's key: element type, dimensions, gradient)."""
    from taichi.lang._ndarray import Ndarray

    def key(value):
        if type(value) is np.ndarray:
            return 0, value.dtype, value.shape[value.ndim - element_dim:] if element_dim else (), value.ndim
        if isinstance(value, Ndarray):
            return 1, value.element_type, len(value.shape), value.grad is not None
        raise _Slow

    return key


def _float_setter(j: int):
    def put(ctx, value):
        if not isinstance(value, (float, int, np.floating, np.integer)):
            raise _Slow
        ctx.set_arg_float((j,), float(value))

    return put


def _int_setter(j: int, signed: bool):
    def put(ctx, value):
        if not isinstance(value, (int, np.integer)):
            raise _Slow
        if signed:
            ctx.set_arg_int((j,), int(value))
        else:
            ctx.set_arg_uint((j,), int(value))

    return put


def _ndarray_setter(j: int, element_dim: int):
    from taichi.lang._ndarray import Ndarray

    def put(ctx, value):
        if type(value) is np.ndarray:
            if not value.flags.c_contiguous or value.size > INT32_MAX:
                raise _Slow
            shape = value.shape[:value.ndim - element_dim] if element_dim else value.shape
            ctx.set_arg_external_array_with_shape((j,), value.ctypes.data, value.nbytes, shape, 0)
        elif isinstance(value, Ndarray):
            if value.grad is None:
                ctx.set_arg_ndarray((j,), value.arr)
            else:
                ctx.set_arg_ndarray_with_grad((j,), value.arr, value.grad.arr)
        else:
            raise _Slow

    return put


class _KernelPath:
    """What the short path needs of one kernel: a keyer per template or ndarray argument, a setter per
    non-template argument, and the plans found so far (signature -> _Plan)."""

    def __init__(self, keyers: list, setters: list, n_args: int) -> None:
        self.keyers = keyers  # (position, key function)
        self.setters = setters  # (position, setter)
        self.n_args = n_args
        self.plans: dict = {}

    @staticmethod
    def of(kernel):
        """The kernel's path, or None where an argument or the return is of a kind it does not cover."""
        from taichi.lang.argpack import ArgPackType
        from taichi.lang.enums import Layout
        from taichi.lang.matrix import MatrixType
        from taichi.lang.util import cook_dtype
        from taichi.types import ndarray_type, primitive_types, template
        from taichi.types.utils import is_signed

        keyers, setters, j = [], [], 0
        for i, argument in enumerate(kernel.arguments):
            anno = argument.annotation
            if isinstance(anno, template):
                keyers.append((i, _template_key))
                continue
            if isinstance(anno, ArgPackType):
                return None
            if id(anno) in primitive_types.real_type_ids:
                setters.append((i, _float_setter(j)))
            elif id(anno) in primitive_types.integer_type_ids:
                setters.append((i, _int_setter(j, is_signed(cook_dtype(anno)))))
            elif isinstance(anno, ndarray_type.NdarrayType) and getattr(anno, "layout", Layout.AOS) == Layout.AOS:
                element_dim = anno.dtype.ndim if isinstance(anno.dtype, MatrixType) else 0
                keyers.append((i, _ndarray_keyer(element_dim)))
                setters.append((i, _ndarray_setter(j, element_dim)))
            else:
                return None
            j += 1
        for ret in kernel.return_type or ():
            if ret not in primitive_types.integer_types and ret not in primitive_types.real_types:
                return None
        return _KernelPath(keyers, setters, len(kernel.arguments))

    def signature(self, args) -> tuple:
        return tuple(key(args[i]) for i, key in self.keyers)


def install() -> bool:
    """Give Taichi's kernels the short launch path (module doc). False where it is in place already, or
    where Taichi runs in its graphical shell (which wraps every call to print the kernel's output)."""
    from taichi.lang import impl, kernel_impl, runtime_ops, shell
    from taichi.lang.enums import AutodiffMode
    from taichi.lang.exception import handle_exception_from_cpp

    Kernel = kernel_impl.Kernel
    if getattr(Kernel, "_short_launch", False) or shell.pybuf_enabled:
        return False
    original = Kernel.__call__
    no_autodiff = AutodiffMode.NONE

    def launch(kernel, plan: _Plan, path: _KernelPath, args):
        """Taichi's `Kernel.launch_kernel` for a known instance: the arguments set, the kernel launched,
        its return values read (after a sync, as Taichi does)."""
        kernel.runtime.materialize()  # fields made since the last launch are placed first, as Taichi does
        ctx = plan.kernel_cpp.make_launch_context()
        for i, put in path.setters:
            put(ctx, args[i])
        prog = plan.prog
        try:
            prog.launch_kernel(prog.compile_kernel(prog.config(), prog.get_device_caps(), plan.kernel_cpp), ctx)
        except Exception as e:  # noqa: BLE001 - re-raised as Taichi re-raises it
            raise handle_exception_from_cpp(e) from None
        ret_types = kernel.return_type
        if not ret_types:
            return None
        runtime_ops.sync()
        out = [kernel.construct_kernel_ret(ctx, ret_type, (k,)) for k, ret_type in enumerate(ret_types)]
        return out[0] if len(out) == 1 else out

    def __call__(self, *args, **kwargs):
        path = self.__dict__.get("_launch_path", False)
        if path is False:
            path = self._launch_path = _KernelPath.of(self)
        rt = self.runtime
        if (path is None or kwargs or len(args) != path.n_args or self.autodiff_mode != no_autodiff
                or self.has_print or rt.fwd_mode_manager or rt.target_tape):
            return original(self, *args, **kwargs)  # autodiff, a tape, a print, other arguments: Taichi's path
        try:
            signature = path.signature(args)
            plan = path.plans.get(signature)
        except (_Slow, TypeError):  # TypeError: an unhashable template argument
            return original(self, *args)
        prog = impl.get_runtime().prog
        if plan is None or plan.prog is not prog or self.compiled_kernels.get(plan.key) is not plan.kernel_cpp:
            result = original(self, *args)  # compiles (or finds) the instance, checks the arguments
            instance_id, _ = self.mapper.lookup(args)
            key = (self.func, instance_id, self.autodiff_mode)
            path.plans[signature] = _Plan(prog, key, self.compiled_kernels[key])
            return result
        try:
            return launch(self, plan, path, args)
        except _Slow:
            return original(self, *args)

    Kernel._taichi_call = original  # Taichi's own path (tests compare with it)
    Kernel.__call__ = __call__
    Kernel._short_launch = True
    return True


__all__ = ["install"]
