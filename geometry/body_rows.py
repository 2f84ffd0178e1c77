"""Which store rows a fracture event takes for a body (geometry/particle_store.py `take_bodies`, Sect.
5.2): its alive particles and the physical parents its subdivided ones came from, kept per body on
the host.

The store found them with a kernel over every row (two passes): 1.3 ms an analysis in Pots, whose
store holds 84-130k rows, and more as a scene grows (issue 16, item 3: an event costs what its body
holds, not what the scene holds). A body's rows change only where the store writes particles
(`ParticleStore.reset` and `put_body`), so the store tells this index what it wrote, and the index
lists anew the bodies those rows belonged to or belong to now.
"""

from __future__ import annotations

import numpy as np

from geometry.particles import KIND_SUBDIVIDED


class BodyRows:
    """Per body, the store rows `take_bodies` gathers, ascending (module doc)."""

    def __init__(self) -> None:
        self._rows: dict[int, np.ndarray] = {}  # body -> (K,) int32 store rows, ascending
        self._body = np.zeros(0, np.int32)  # (rows,) -: each row's body while alive, else -1
        self._parent = np.zeros(0, np.int64)  # (rows,) -: an alive subdivided row's parent row, else -1

    def reset(self, body: np.ndarray, alive: np.ndarray, kind: np.ndarray, parent: np.ndarray) -> None:
        """The whole store: per row (N,) its body, alive flag, kind and parent row (-1: none)."""
        self._rows = {}
        self._body = np.zeros(0, np.int32)
        self._parent = np.zeros(0, np.int64)
        self.write(np.arange(len(body)), body, alive, kind, parent)

    def write(self, rows: np.ndarray, body: np.ndarray, alive: np.ndarray, kind: np.ndarray,
              parent: np.ndarray) -> None:
        """Store rows `rows` (K,), each once, now hold these values (per row, as `reset`; parent as a store
        row)."""
        rows = np.asarray(rows, np.int64)
        body, parent = np.asarray(body, np.int64), np.asarray(parent, np.int64)
        live = np.asarray(alive, bool) & (body >= 0)
        self._grow(int(rows.max()) + 1 if len(rows) else 0)
        before = self._body[rows]
        self._body[rows] = np.where(live, body, -1)
        self._parent[rows] = np.where(live & (np.asarray(kind) == KIND_SUBDIVIDED), parent, -1)
        was = before[before >= 0]
        affected = np.flatnonzero(np.bincount(np.concatenate([was, body[live]]), minlength=1))
        # a body's alive rows after the write: the rewritten rows now its, and its listed rows not rewritten
        ascending = rows if np.all(rows[1:] > rows[:-1]) else np.sort(rows)
        candidate = [rows]
        for b in affected.tolist():
            listed = self._rows.pop(b, None)
            if listed is not None and len(ascending):
                at = np.minimum(np.searchsorted(ascending, listed), len(ascending) - 1)
                candidate.append(listed[ascending[at] != listed])
            elif listed is not None:
                candidate.append(listed)
        candidate = np.concatenate(candidate)
        owner = self._body[candidate].astype(np.int64)
        mine = np.zeros(int(affected.max(initial=-1)) + 2, bool)  # (bodies + 1,) flag of the affected bodies
        mine[affected] = True
        keep = mine[np.where((owner >= 0) & (owner < len(mine)), owner, -1)]  # alive and of an affected body
        candidate, owner = candidate[keep], owner[keep]
        par = self._parent[candidate]
        child = par >= 0
        # (body, row) as one key, sorted: each body's rows and its subdivided rows' parents, ascending, once
        span = len(self._body)
        key = np.concatenate([owner * span + candidate, owner[child] * span + par[child]])
        key.sort()
        key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # a parent of several children
        owner, row = np.divmod(key, span)
        first = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]]) if len(key) else np.zeros(0, np.int64)
        for a, b in zip(first.tolist(), np.r_[first[1:], len(owner)].tolist()):
            self._rows[int(owner[a])] = row[a:b].astype(np.int32)

    def rows(self, bodies) -> np.ndarray:
        """(K,) int32 store rows of `bodies`, ascending, each once."""
        parts = [self._rows[b] for b in {int(b) for b in bodies} if b in self._rows]
        if not parts:
            return np.zeros(0, np.int32)
        return parts[0].copy() if len(parts) == 1 else np.unique(np.concatenate(parts))

    def _grow(self, n: int) -> None:
        if n > len(self._body):
            extra = max(n, 2 * len(self._body)) - len(self._body)
            self._body = np.concatenate([self._body, np.full(extra, -1, np.int32)])
            self._parent = np.concatenate([self._parent, np.full(extra, -1, np.int64)])
