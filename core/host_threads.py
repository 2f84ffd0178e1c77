"""Host numpy work on every core (issue 16: "parallelise across the two cores where it pays").

The numpy form of the fracture analysis' neighbour search and Eq. 7 (sph/gradient.py: where Taichi
has not started, and on CUDA; a CPU run uses its kernels) is numpy and scipy work on independent
blocks of particles; numpy's array loops, LAPACK and cKDTree release the GIL, so
blocks run side by side on threads. `ordered_map(fn, items)` returns the results in the items' order
and every block is the same arithmetic wherever it runs, so results never depend on the number of
threads (tests/unit/test_host_threads.py). Taichi kernels are never launched from these threads.

The pool is made at first use (nothing at import) with one thread per core this process may run on
(`os.sched_getaffinity`), one per process (a forked child makes its own); with one core, one item,
or when called from one of its own threads, the work runs in the caller's thread.
"""

from __future__ import annotations

import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor

_inside = threading.local()  # set in the pool's threads: work they map runs in line (no nested waits)


def host_cores() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _pool() -> ThreadPoolExecutor | None:
    return _pool_of(os.getpid())  # a forked child makes its own (its parent's threads are not in it)


@functools.cache
def _pool_of(pid: int) -> ThreadPoolExecutor | None:
    n = host_cores()
    return ThreadPoolExecutor(max_workers=n, thread_name_prefix="host", initializer=_mark) if n > 1 else None


def _mark() -> None:
    _inside.pool = True


def ordered_map(fn, items) -> list:
    """[fn(item) for item in items], the items spread over the host threads."""
    items = list(items)
    pool = _pool()
    if pool is None or len(items) < 2 or getattr(_inside, "pool", False):
        return [fn(item) for item in items]
    return list(pool.map(fn, items))
