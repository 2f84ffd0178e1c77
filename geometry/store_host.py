"""The particle store's copies on the CPU backend (geometry/particle_store.py; issue 16: start-up and
the event's time): numpy on views of the store's own ndarray memory instead of its kernels.

On the CPU a Taichi ndarray lives in host memory, and its address is known
(`Program.get_ndarray_data_ptr_as_int`): `host_views` wraps each of the store's ndarrays in a numpy
array over that memory (core/host_memory.py: no copy, each view keeps its ndarray alive, and views
and kernels see each other's writes). The store's kernels (geometry/store_kernels.py) only copy rows,
yet each costs its frontend and an LLVM JIT in every process: 0.9 s of the pot's 3.7 s of compiling
here (session 45), all of it before the first frame of a scene struck at once. The functions below
make the same copies with numpy, to the bit (the kernels' arithmetic is copying, id remapping and,
for the per-body mass, a sum in row order, which `np.bincount` keeps): the kernels stay for CUDA, and
the tests run both.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from core.host_memory import array_at, host_memory
from geometry.store_checks import host_first_invalid


def host_views(arrays: dict) -> dict[str, np.ndarray] | None:
    """name -> numpy view of each Taichi ndarray's memory, or None where that memory is not the host's
    (a backend other than the CPU)."""
    from taichi.lang import impl
    from taichi.lang.util import to_numpy_type

    if not host_memory():
        return None
    prog = impl.get_runtime().prog
    return {name: array_at(prog.get_ndarray_data_ptr_as_int(nd.arr), to_numpy_type(nd.dtype), tuple(nd.shape),
                           owner=nd) for name, nd in arrays.items()}


def _local(slot: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Store ids (int32) -> local ids of the gathered rows (`slot`: local index + 1, 0 outside them): -1
    stays -1, an id outside the gathered rows becomes -2 - id (read as 'no link' by the host code)."""
    s = np.take(slot, ids)  # -1 reads the last row: set right below
    out = np.where(s > 0, s - 1, -2 - ids)
    out[ids < 0] = -1
    return out


def take(v: dict, ids: np.ndarray, extra_count: int, columns: dict) -> tuple[dict, np.ndarray, np.ndarray]:
    """`k_gather` and `k_gather_extra`: rows `ids` of the columns (`columns`: name -> the dtype the kernel
    gives), and of the parents and links with particle ids made local; the store rows of the live extra
    links with both ends among them (ascending) and those links with local ids."""
    ids = np.asarray(ids, np.int64)
    slot = v["particle_slot"]
    slot[ids] = np.arange(1, len(ids) + 1, dtype=np.int32)
    # np.take: a third of fancy indexing's time for the (K, 4, 3) and (K, 3, 3) columns
    cols = {name: np.take(v[name], ids, axis=0).astype(dtype, copy=False) for name, dtype in columns.items()}
    cols["particle_parent"] = _local(slot, np.take(v["particle_parent"], ids))
    cols["particle_links"] = _local(slot, np.take(v["particle_links"], ids, axis=0))
    ends = np.take(slot, v["link_extra"][:extra_count])  # (E, 2) local index + 1 of both ends, 0 outside
    both = (ends[:, 0] > 0) & (ends[:, 1] > 0) & (v["link_extra_alive"][:extra_count] != 0)
    rows = np.flatnonzero(both).astype(np.int32)
    pairs = (ends[rows] - 1).astype(np.int32).reshape(-1, 2)
    slot[ids] = 0
    return cols, rows, pairs


def put(v: dict, ids: np.ndarray, host: dict, made: bool, fixed: tuple, changing: tuple) -> None:
    """`k_put`: host rows into store rows `ids`, the changing columns, and the fixed ones when `made`."""
    for name in (*fixed, *changing) if made else changing:
        v[name][ids] = host[name]


def replace_extra(v: dict, kill: np.ndarray, first: int, pairs: np.ndarray) -> None:
    """`k_replace_extra`: extra links `kill` removed, `pairs` appended from row `first` on."""
    v["link_extra_alive"][kill] = 0
    v["link_extra"][first:first + len(pairs)] = pairs
    v["link_extra_alive"][first:first + len(pairs)] = 1


def compact_extra(v: dict, extra_count: int) -> int:
    """`k_compact_extra`: the live extra links moved to the front, in order; returns how many."""
    alive = v["link_extra_alive"]
    live = np.flatnonzero(alive[:extra_count] != 0)
    v["link_extra"][:len(live)] = v["link_extra"][live]
    alive[:extra_count] = 0
    alive[:len(live)] = 1
    return len(live)


def body_totals(v: dict, count: int, n_bodies: int) -> tuple[np.ndarray, np.ndarray]:
    """`k_body_totals`: alive particles (B,) and their mass (B,) kg per body below n_bodies (at least 1
    row), summed in row order as the one-thread kernel sums."""
    body = v["particle_body"][:count]
    rows = np.flatnonzero((v["particle_alive"][:count] != 0) & (body >= 0) & (body < n_bodies))
    size = max(1, n_bodies)
    return (np.bincount(body[rows], minlength=size).astype(np.int32),
            np.bincount(body[rows], weights=v["particle_mass"][rows], minlength=size))


def first_invalid(v: dict, count: int, rows: np.ndarray | None, check_kernel: bool) -> np.ndarray:
    """`k_first_invalid`: per check the first alive row that fails it, or `count`; over `rows`
    (ascending) or, for None, every row in use."""
    at = np.arange(count) if rows is None else np.asarray(rows, np.int64)
    if len(at) == 0:
        return np.full(5, count, np.int32)

    def col(name: str) -> np.ndarray:
        return v[name][:count] if rows is None else np.take(v[name], at, axis=0)

    # the columns host_first_invalid reads, at those rows
    taken = SimpleNamespace(alive=col("particle_alive") != 0, centroid=col("particle_centroid"),
                            rest_verts=col("particle_rest_verts"), volume=col("particle_volume"),
                            mass=col("particle_mass"))
    first = host_first_invalid(taken, col("particle_kernel") if check_kernel else None, len(at))
    return np.where(first < len(at), at[np.minimum(first, len(at) - 1)], count).astype(np.int32)


__all__ = ["body_totals", "compact_extra", "first_invalid", "host_views", "put", "replace_extra", "take"]
