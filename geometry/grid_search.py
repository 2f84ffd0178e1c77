"""Point pairs within a distance, and the components of a graph, in numpy alone (no scipy).

The fragment surfaces (geometry/surface.py) are made in the drawing process too, for every fracture
event, and importing scipy there costs 0.45 s of that process (docs/decisions.md, session 36): a
frame waited for it. Their searches are small (a crack's open edges and faces), so a uniform grid
over the points does them: `pairs_within` is `cKDTree.query_ball_point` and
`sparse_distance_matrix`'s pair list, `components` is `connected_components` of an undirected
graph (tests/unit/test_grid_search.py checks both against scipy). A `PointGrid` is kept where the
same points are searched again (the rest surface, at every event).
"""

from __future__ import annotations

import numpy as np

_OFFSETS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], dtype=np.int64)
FINEST_REL = 1e-6  # the grid's cell is at least this share of the points' extent (keys stay in int64)


class PointGrid:
    """Data points (D, 3) in a uniform grid of `cell` (m), sorted once: `pairs` then finds the query
    points' neighbours within a radius up to `cell` (the rest surface's search, kept between events)."""

    def __init__(self, data: np.ndarray, cell: float) -> None:
        self.data = np.asarray(data, dtype=np.float64).reshape(-1, 3)
        d = self.data
        self.lo = d.min(0) if len(d) else np.zeros(3)
        extent = float(np.max(d.max(0) - self.lo)) if len(d) else 0.0
        self.cell = max(float(cell), FINEST_REL * extent, 1e-300)
        dc = np.floor((d - self.lo) / self.cell).astype(np.int64) + 1  # cells 1..n: a neighbour is >= 0
        self.span = (dc.max(0) if len(d) else np.zeros(3, np.int64)) + 2
        keys = self._key(dc)
        self.order = np.argsort(keys, kind="stable")
        self.sorted_keys = keys[self.order]

    def _key(self, c: np.ndarray) -> np.ndarray:
        """Cell key; -1 for a cell outside the grid's box (it holds no point)."""
        inside = np.all((c >= 0) & (c < self.span), axis=1)
        return np.where(inside, (c[:, 0] * self.span[1] + c[:, 1]) * self.span[2] + c[:, 2], -1)

    def pairs(self, query: np.ndarray, radius) -> tuple[np.ndarray, np.ndarray]:
        """(i, j) int64, sorted by i then j: query point i (Q, 3) and data point j within `radius` (a
        scalar or one per query point, m, at most the cell)."""
        q = np.asarray(query, dtype=np.float64).reshape(-1, 3)
        r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (len(q),))
        none = np.zeros(0, np.int64)
        if len(q) == 0 or len(self.data) == 0:
            return none, none
        if float(r.max()) > self.cell:
            raise ValueError(f"radius {float(r.max())} m above the grid's cell {self.cell} m")
        qc = np.floor((q - self.lo) / self.cell).astype(np.int64) + 1
        rows, cols = [], []
        for off in _OFFSETS:
            k = self._key(qc + off)
            start = np.searchsorted(self.sorted_keys, k, "left")
            count = np.where(k >= 0, np.searchsorted(self.sorted_keys, k, "right") - start, 0)
            total = int(count.sum())
            if total == 0:
                continue
            rows.append(np.repeat(np.arange(len(q)), count))
            cols.append(self.order[np.arange(total) - np.repeat(np.cumsum(count) - count, count)
                                   + np.repeat(start, count)])
        if not rows:
            return none, none
        i, j = np.concatenate(rows), np.concatenate(cols)
        gap = q[i] - self.data[j]
        near = np.einsum("ij,ij->i", gap, gap) <= r[i] * r[i]
        i, j = i[near], j[near]
        sort = np.lexsort((j, i))
        return i[sort], j[sort]


def pairs_within(query: np.ndarray, data: np.ndarray, radius) -> tuple[np.ndarray, np.ndarray]:
    """(i, j) int64, sorted by i then j: every query point i (Q, 3) and data point j (D, 3) with
    |query[i] - data[j]| <= radius (a scalar or one per query point, m)."""
    r = np.asarray(radius, dtype=np.float64)
    return PointGrid(data, float(r.max()) if r.size else 0.0).pairs(query, radius)


def components(n: int, a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """(count, label (n,) int64 in 0..count-1): the connected components of the undirected graph on n
    nodes with edges (a[k], b[k]); labels in the order of each component's smallest node."""
    label = np.arange(n, dtype=np.int64)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    while True:  # each node takes the least label at its edges, then its label's label (halving)
        least = np.minimum(label[a], label[b])
        new = label.copy()
        np.minimum.at(new, a, least)
        np.minimum.at(new, b, least)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    roots, comp = np.unique(label, return_inverse=True)
    return len(roots), comp.ravel().astype(np.int64)


__all__ = ["PointGrid", "components", "pairs_within"]
