"""Taichi field trees kept for reuse instead of destroyed (DESIGN.md 3, stores of fixed capacity).

Taichi 1.7.4's `SNodeTree.destroy` clears every compiled kernel of the program (its comment: kernels
hold pointers into the destroyed tree's SNodes), so releasing one store made every later kernel
launch in the process compile again from the offline cache: 0.6 s of a second World's first frame
without drawing, 7 s of its first raster frame. A store that is done gives its fields back here,
keyed by what they hold (kind and capacities); the next store with the same key takes them, with the
kernels already compiled for them (kernels take fields, or a data-oriented owner, as template
arguments, which Taichi keys by identity). Capacities are powers of two so that stores of similar
scenes share keys. The content of a recycled item is stale: its new owner writes what it reads.
Nothing is ever destroyed while the process runs; what the pool holds is bounded by the largest set
of stores alive at once for each key.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TypeVar

T = TypeVar("T")

_FREE: dict[Hashable, list] = {}  # key -> items given back and not taken again


def pow2_at_least(n: int, smallest: int = 1) -> int:
    """The smallest power of two >= max(n, smallest)."""
    p = 1
    while p < max(int(n), int(smallest)):
        p *= 2
    return p


def acquire(key: Hashable, make: Callable[[], T]) -> T:
    """An item given back under `key` if there is one, else `make()`."""
    free = _FREE.get(key)
    return free.pop() if free else make()


def recycle(key: Hashable, item) -> None:
    """Give `item` back under `key` (its owner must not use it afterwards)."""
    _FREE.setdefault(key, []).append(item)

