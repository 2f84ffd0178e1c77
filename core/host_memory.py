"""Numpy arrays over memory Taichi owns, where that memory is the host's (issue 16: the stores' host
copies without kernels; geometry/store_host.py, rigid/host_views.py).

On the CPU backend a Taichi ndarray's or field's memory is host memory at a known address
(`Program.get_ndarray_data_ptr_as_int`, `ti.get_addr` in a kernel), and CPU kernels finish before
their launch returns, so a numpy array over that memory reads what the last kernel wrote and a kernel
reads what numpy wrote, with no copy and nothing compiled. Elsewhere (CUDA) the memory is the
device's and the callers copy with kernels.
"""

from __future__ import annotations

import ctypes

import numpy as np


def host_memory() -> bool:
    """Whether Taichi runs on the CPU backend, where its memory is the host's."""
    from core.runtime import started_on_cpu

    return started_on_cpu()


def array_at(address: int, dtype, shape: tuple, strides: tuple | None = None, owner=None) -> np.ndarray:
    """A numpy array of `shape` and `dtype` over the memory at `address` (C order, or `strides` in
    bytes); `owner` (the ndarray or field the memory belongs to) is kept alive as long as the array."""
    dtype = np.dtype(dtype)
    strides = strides or tuple(int(np.prod(shape[i + 1:])) * dtype.itemsize for i in range(len(shape)))
    extent = sum((n - 1) * s for n, s in zip(shape, strides)) + dtype.itemsize if all(shape) else dtype.itemsize
    buf = (ctypes.c_byte * extent).from_address(int(address))
    buf.owner = owner
    return np.ndarray(shape, dtype=dtype, buffer=buf, strides=strides)


__all__ = ["array_at", "host_memory"]
