"""Array helpers shared by the geometry, rigid and render code (numpy only).

`group_indices` splits indices by label with one stable sort, where a loop of `labels == b` masks
costs a pass over every label per group.

`unique_rows` is `np.unique(rows, axis=0)` for integer rows (tet faces, links, edges, body pairs) by one
int64 key per row: numpy sorts rows as a structured view, about 10x slower (150k sorted vertex pairs:
157 ms against 16 ms). The keys sort as the rows do, so the result is the same, bit for bit. Float rows
(the corners of a struck patch) are sorted by one lexsort instead: the same rows in the same order
(0.09 ms against 0.44 for a patch's few hundred corners; -0.0 and 0.0 are one value, as for numpy).

`cross3` is `np.cross` for 3-vectors: the same products and differences in the same dtype, so the same
bits, without np.cross' axis handling, which costs 20-30 us for one pair of vectors (a fracture
event made about 70 such calls).
"""

from __future__ import annotations

import numpy as np

KEY_LIMIT = 1 << 62  # largest product of the column spans packed into one int64 key


def unique_rows(rows: np.ndarray, return_inverse: bool = False, return_counts: bool = False):
    """What `np.unique(rows, axis=0, return_inverse=..., return_counts=...)` returns for an (N, K)
    integer or float array: the distinct rows in lexicographic order, then the (N,) index of each row's
    distinct row and the count of each, as asked."""
    rows = np.asarray(rows)
    kind_ok = np.issubdtype(rows.dtype, np.integer) or np.issubdtype(rows.dtype, np.floating)
    if rows.ndim != 2 or not kind_ok:
        raise ValueError(f"unique_rows takes an (N, K) integer or float array, got shape {rows.shape} of {rows.dtype}")
    if len(rows) == 0:
        uniq, inverse, counts = rows[:0], np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    elif np.issubdtype(rows.dtype, np.floating):  # by one lexsort, first column most significant
        order = np.lexsort(rows.T[::-1])
        ordered = rows[order]
        new = np.r_[True, (ordered[1:] != ordered[:-1]).any(axis=1)]
        uniq = ordered[new]
        inverse = np.empty(len(rows), dtype=np.int64)
        inverse[order] = np.cumsum(new) - 1
        counts = np.diff(np.r_[np.flatnonzero(new), len(rows)])
    else:
        lo = rows.min(axis=0).astype(np.int64)
        span = rows.max(axis=0).astype(np.int64) - lo + 1
        if float(np.prod(span.astype(np.float64))) >= KEY_LIMIT:  # no room for one key: numpy's own way
            uniq, inverse, counts = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
        else:
            key = np.zeros(len(rows), dtype=np.int64)
            for c in range(rows.shape[1]):  # mixed radix, first column most significant: sorts like the rows
                key = key * span[c] + (rows[:, c].astype(np.int64) - lo[c])
            _, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
            uniq = rows[first]
    out = (uniq,)
    if return_inverse:
        out += (inverse.ravel(),)
    if return_counts:
        out += (counts,)
    return out if len(out) > 1 else out[0]


def cross3(a, b) -> np.ndarray:
    """`np.cross(a, b)` for (..., 3) arrays (broadcast as np.cross does), bit for bit: each component is
    one product minus another, both rounded, in the promoted dtype (numpy's own order). Two float64
    3-vectors are done in Python floats, which round as float64 does."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape == (3,) and b.shape == (3,) and a.dtype == np.float64 and b.dtype == np.float64:
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    if a.shape[-1:] != (3,) or b.shape[-1:] != (3,):
        raise ValueError(f"cross3 takes (..., 3) arrays, got shapes {a.shape} and {b.shape}")
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.promote_types(a.dtype, b.dtype))
    for k, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        np.multiply(a[..., i], b[..., j], out=out[..., k])
        out[..., k] -= a[..., j] * b[..., i]
    return out


def group_indices(labels: np.ndarray) -> list[np.ndarray]:
    """The indices of each distinct label (N,), ascending within a group, groups in label order."""
    labels = np.asarray(labels).reshape(-1)
    order = np.argsort(labels, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(labels[order])) + 1) if len(labels) else []


__all__ = ["group_indices", "unique_rows"]
