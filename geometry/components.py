"""Connected components of the particle graph, numbered by their smallest particle (Sect. 5.2: the
fragments a fracture event leaves are the components of the links that remain; geometry/fragments.py).

On a started CPU runtime one serial kernel does it: union-find over the links, then one pass over the
particles in ascending order that numbers each component when its first (smallest) particle comes.
scipy's sparse graph (a CSR matrix and `connected_components`) took 2.7 ms of each Pots cut; the kernel
about a tenth of that. Before Taichi starts (geometry alone, `main.py check`) and on CUDA, scipy
answers: the numbering is the same (tests/unit/test_components.py compares the two on random graphs).
No `from __future__ import annotations` here: Taichi reads the kernel's annotations as objects.
"""

import functools

import numpy as np

from core.runtime import started_on_cpu


@functools.cache
def _kernel():
    """The serial labelling kernel, defined at first use (importing geometry starts no Taichi)."""
    import taichi as ti

    @ti.func
    def root(parent: ti.template(), i):
        r = i
        while parent[r] != r:
            r = parent[r]
        k = i
        while parent[k] != r:  # path compression: later finds are short
            nxt = parent[k]
            parent[k] = r
            k = nxt
        return r

    @ti.kernel
    def k_component_labels(rows: ti.types.ndarray(), cols: ti.types.ndarray(), ids: ti.types.ndarray(),
                           parent: ti.types.ndarray(), labels: ti.types.ndarray()):
        for _ in range(1):  # one serial task: the union order and the numbering are sequential
            for e in range(rows.shape[0]):
                a = root(parent, rows[e])
                b = root(parent, cols[e])
                if a != b:
                    parent[ti.max(a, b)] = ti.min(a, b)
            nxt = 0
            for t in range(ids.shape[0]):  # ascending: a component's first particle is its smallest
                r = root(parent, ids[t])
                if labels[r] < 0:
                    labels[r] = nxt
                    nxt += 1
                labels[ids[t]] = labels[r]

    return k_component_labels


def component_labels(n: int, ids: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(n,) int64: the component of each of the particles `ids` (ascending) over the undirected links
    (rows[e], cols[e]) among them, numbered 0.. in order of each component's smallest particle; -1 for
    the particles not in `ids`."""
    ids = np.asarray(ids, np.int64)
    if not started_on_cpu():
        return component_labels_reference(n, ids, rows, cols)
    parent = np.arange(n, dtype=np.int32)
    labels = np.full(n, -1, np.int32)
    _kernel()(np.ascontiguousarray(rows, np.int32), np.ascontiguousarray(cols, np.int32),
              np.ascontiguousarray(ids, np.int32), parent, labels)
    out = np.full(n, -1, np.int64)
    out[ids] = labels[ids]
    return out


def component_labels_reference(n: int, ids: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """`component_labels` by scipy's sparse graph: the specification the kernel is tested against."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n, n)).tocsr()
    _, comp = connected_components(g, directed=False)
    labels = np.full(n, -1, dtype=np.int64)
    if len(ids):
        # renumber by first appearance (ids ascending -> smallest member first)
        _, first, inv = np.unique(comp[ids], return_index=True, return_inverse=True)
        rank = np.empty(first.size, dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(first.size)
        labels[ids] = rank[inv.ravel()]
    return labels


def warm_up() -> None:
    """Launch the kernel on nothing: it compiles, for sim/warm_up.py, before an event needs it."""
    if started_on_cpu():
        nothing = np.zeros(0, np.int64)
        component_labels(0, nothing, nothing, nothing)
