"""Taichi 1.7.4's small-matrix operations built straight into the kernel's IR (issue 16: start to
first frame), the same operations in the same order as Taichi's own.

Taichi writes `A @ b`, `A.transpose()`, `a.cross(b)`, `a.dot(b)`, `a.norm()`, `a.norm_sqr()` and
`a.sum()` in kernels as `ti.func`s of `taichi/lang/matrix_ops.py` with statically unrolled loops, so
its Python frontend walks their syntax trees again at every use: a 3x3 matrix times a vector is about
100 AST nodes, and these functions were 40% of the 49k nodes the pot's first frame transforms.
`install()` replaces those module functions with plain Python that emits, for the shapes the scenes
use, what the inlined `ti.func` emits: each argument copied into a local (a `ti.func` argument is
passed by value), the same products and sums in the same association order, the result of a matrix
product and of a reduction in a local, a cross product as a matrix expression. Taichi's passes
forward the locals either way, so the compiled arithmetic is the same: tests/unit/test_taichi_matrix.py
compiles one kernel both ways and compares every result bit for bit, in f32 and f64. Any other shape,
an argument that is not a Taichi expression, and a call outside a kernel go to Taichi's function,
with its checks and messages. Only the building of a kernel changes; Taichi's offline cache keys the
built IR, so the first start after this change compiles every kernel once.
"""

from __future__ import annotations

REPLACED = ("matmul", "transpose", "cross", "dot", "sum", "norm_sqr", "norm")


def _local(value):
    from taichi.lang import impl

    return impl.expr_init(value)


def _at(value, *index):
    from taichi.lang import impl

    return impl.subscript(None, value, *index)


def _tensors(*values) -> bool:
    from taichi.lang import impl
    from taichi.lang.expr import Expr

    return impl.inside_kernel() and all(isinstance(v, Expr) and v.is_tensor() for v in values)


def _reduced(mat):
    """matrix_ops._reduce(mat, add) of a local: mat[0] (mat[0, 0]), then + each later element in order."""
    shape = mat.get_shape()
    order = [(i,) for i in range(shape[0])] if len(shape) == 1 else \
        [(i, j) for i in range(shape[0]) for j in range(shape[1])]
    total = _at(mat, *order[0])
    for index in order[1:]:
        total = total + _at(mat, *index)
    return _local(total)


def _matmul(original):
    def matmul(x, y):
        if not _tensors(x, y):
            return original(x, y)
        sx, sy = x.get_shape(), y.get_shape()
        if len(sx) != 2 or len(sy) not in (1, 2) or sx[1] != sy[0]:
            return original(x, y)  # a vector on the left, or a shape error: Taichi's path and message
        from taichi.lang.matrix import make_matrix

        X, Y = _local(x), _local(y)
        if len(sy) == 1:
            zero = _local(_at(X, 0, 0) * _at(Y, 0) * 0)  # matrix_ops: for the result's type
            rows = []
            for i in range(sx[0]):
                acc = zero
                for k in range(sx[1]):
                    acc = acc + _at(X, i, k) * _at(Y, k)
                rows.append(acc)
            return _local(make_matrix(rows))
        zero = _local(_at(X, 0, 0) * _at(Y, 0, 0) * 0)
        rows = []
        for i in range(sx[0]):
            row = []
            for j in range(sy[1]):
                acc = zero
                for k in range(sx[1]):
                    acc = acc + _at(X, i, k) * _at(Y, k, j)
                row.append(acc)
            rows.append(row)
        return _local(make_matrix(rows))

    return matmul


def _transpose(original):
    def transpose(mat):
        if not (_tensors(mat) and len(mat.get_shape()) == 2):
            return original(mat)
        from taichi.lang.matrix import make_matrix

        M = _local(mat)
        n, m = mat.get_shape()
        return make_matrix([[_at(M, i, j) for i in range(n)] for j in range(m)])

    return transpose


def _cross(original):
    def cross(x, y):
        if not (_tensors(x, y) and x.get_shape() == (3,) and y.get_shape() == (3,)):
            return original(x, y)
        from taichi.lang.matrix import make_matrix

        X, Y = _local(x), _local(y)
        a = [_at(X, i) for i in range(3)]
        b = [_at(Y, i) for i in range(3)]
        return make_matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])

    return cross


def _dot(original):
    def dot(x, y):
        if not (_tensors(x, y) and len(x.get_shape()) == 1 and x.get_shape() == y.get_shape()):
            return original(x, y)
        return _reduced(_local(_local(x) * _local(y)))  # sum(vec_x * vec_y)

    return dot


def _sum(original):
    def sum(mat):  # noqa: A001 (Taichi's name)
        if not _tensors(mat):
            return original(mat)
        return _reduced(_local(mat))

    return sum


def _norm_sqr(original):
    def norm_sqr(mat):
        if not _tensors(mat):
            return original(mat)
        m = _local(mat)
        return _reduced(_local(m * m))  # sum(mat * mat)

    return norm_sqr


def _norm(original, norm_sqr):
    def norm(mat, eps=0.0):
        if not _tensors(mat):
            return original(mat, eps)
        from taichi.lang import ops

        m, e = _local(mat), _local(eps)
        return ops.sqrt(norm_sqr(m) + e)

    return norm


def install() -> None:
    """Replace matrix_ops' functions by the direct builds (idempotent)."""
    from taichi.lang import matrix_ops

    if getattr(matrix_ops.matmul, "direct", False):
        return
    built = {
        "matmul": _matmul(matrix_ops.matmul),
        "transpose": _transpose(matrix_ops.transpose),
        "cross": _cross(matrix_ops.cross),
        "dot": _dot(matrix_ops.dot),
        "sum": _sum(matrix_ops.sum),
        "norm_sqr": _norm_sqr(matrix_ops.norm_sqr),
    }
    built["norm"] = _norm(matrix_ops.norm, built["norm_sqr"])
    for name in REPLACED:
        fn, original = built[name], getattr(matrix_ops, name)
        # named as Taichi's: the frontend takes a `taichi.*` function called in a kernel for its own
        # (no "non-taichi function" warning), and its errors name the operation
        fn.__module__, fn.__name__, fn.__qualname__, fn.__doc__ = (matrix_ops.__name__, original.__name__,
                                                                   original.__qualname__, original.__doc__)
        fn.direct = True
        fn.original = original
        setattr(matrix_ops, name, fn)
