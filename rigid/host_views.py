"""Numpy views of Taichi fields on the CPU backend: the rigid store's (rigid/host_sync.py) and the
debris' (rigid/debris.py, `field_views`); issue 16: start-up.

The host's copies to and from the rigid store (bodies, spheres, colliders, contacts, the warm-start
contacts: rigid/transfers.py) were nine kernels that only move values, yet each costs its frontend
and an LLVM JIT in every process (0.8 s of the pot's 2.8 s of compiling here, session 45), and
Taichi's own accessor for each field read or written from Python (`field[None]`) is compiled too.
On the CPU a field's memory is the host's: every field of rigid/store.py is placed in a dense node of
its own (or, the scalars, together in the root), so its rows lie at a fixed stride from its first,
components side by side. One kernel reads those addresses (`ti.get_addr` of rows 0 and 1);
`store_views` wraps each field in a numpy array over that memory, which reads and writes it with no
copy (core/host_memory.py). The copies are then numpy assignments with the
kernels' conversions (to the store's float, rounding to nearest), so the same bits. Elsewhere (CUDA)
the kernels run. No `from __future__ import annotations` here: Taichi reads the kernel's annotations.
"""

import numpy as np
import taichi as ti

from core.host_memory import array_at, host_memory

# the fields the host copies read or write (rigid/transfers.py), each viewed through its rows 0 and 1
ROWS = ("body_inv_mass", "body_ref_com", "body_inv_inertia", "body_principal_q", "body_inv_principal",
        "body_restitution", "body_friction", "body_static", "body_alive", "body_x", "body_q", "body_v", "body_w",
        "body_asleep", "body_sleep_time", "bp_local", "bp_radius", "bp_body", "bp_pc_start", "col_kind", "col_x",
        "col_q", "col_n", "col_half", "col_restitution", "col_friction", "ct_a", "ct_b", "ct_body_a", "ct_body_b",
        "ct_p", "ct_n", "ct_ltot", "ct_vn0", "ct_sep", "pc_b", "pc_ln", "pc_lt")
SCALARS = ("pc_valid", "max_closing")  # 0-D fields read or written from the host
N_ROWS = len(ROWS)
UNROLL = 16  # fields per statically unrolled block (Taichi warns above 32 iterations of one loop)


@ti.kernel
def k_addresses(s: ti.template(), out: ti.types.ndarray()):
    """out[2k], out[2k + 1]: the addresses of rows 0 and 1 of field ROWS[k]; then those of SCALARS."""
    for first in ti.static(range(0, N_ROWS, UNROLL)):
        for k in ti.static(range(first, min(first + UNROLL, N_ROWS))):
            out[2 * k] = ti.get_addr(ti.static(getattr(s, ROWS[k])), 0)
            out[2 * k + 1] = ti.get_addr(ti.static(getattr(s, ROWS[k])), 1)
    for k in ti.static(range(len(SCALARS))):
        out[2 * N_ROWS + k] = ti.get_addr(ti.static(getattr(s, SCALARS[k])), [])


def store_views(s) -> dict[str, np.ndarray] | None:
    """name -> numpy view of each field of ROWS (the store's rows, then the element's shape) and of
    SCALARS (shape ()), or None where the fields' memory is not the host's."""
    return field_views(s, ROWS, SCALARS, lambda addr: k_addresses(s, addr))


def field_views(owner, rows: tuple, scalars: tuple, addresses) -> dict[str, np.ndarray] | None:
    """name -> numpy view of each field `owner.<name>`: those of `rows` placed in dense nodes (rows,
    then the element's shape), those of `scalars` 0-D; None off the CPU backend. `addresses(addr)`
    fills addr (uint64) with the addresses of rows 0 and 1 of each of `rows`, then those of `scalars`
    (a kernel of ti.get_addr, as `k_addresses`)."""
    if not host_memory():
        return None
    addr = np.zeros(2 * len(rows) + len(scalars), np.uint64)
    addresses(addr)
    views = {}
    for k, name in enumerate(rows):
        first, second = int(addr[2 * k]), int(addr[2 * k + 1])
        views[name] = _view(getattr(owner, name), first, second - first)
    for k, name in enumerate(scalars):
        views[name] = _view(getattr(owner, name), int(addr[2 * len(rows) + k]), 0)
    return views


def _view(field, first: int, stride: int) -> np.ndarray:
    """A numpy array over a field's memory: its rows `stride` bytes apart from address `first`, each
    row's components side by side (a 0-D field: one value)."""
    from taichi.lang.matrix import MatrixField
    from taichi.lang.util import to_numpy_type

    dtype = np.dtype(to_numpy_type(field.dtype))
    element = () if not isinstance(field, MatrixField) else (field.n,) if field.ndim == 1 else (field.n, field.m)
    per_row = int(np.prod(element)) * dtype.itemsize
    if not field.shape:
        return array_at(first, dtype, (), owner=field)
    if stride < per_row:
        raise RuntimeError(f"a field's rows lie {stride} bytes apart but hold {per_row} bytes")
    inner = tuple(int(np.prod(element[i + 1:])) * dtype.itemsize for i in range(len(element)))
    return array_at(first, dtype, (field.shape[0], *element), (stride, *inner), owner=field)


__all__ = ["ROWS", "SCALARS", "field_views", "k_addresses", "store_views"]
