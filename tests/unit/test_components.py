"""The fragments' labels (geometry/components.py): the kernel's union-find numbers the components of
random graphs exactly as scipy's connected_components renumbered by their smallest particle."""

import numpy as np
import pytest

from geometry.components import component_labels, component_labels_reference


@pytest.mark.parametrize("seed", range(6))
def test_kernel_labels_are_scipys(seed, taichi_runtime):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    edges = int(rng.integers(0, 2 * n))  # from isolated particles to one component
    rows, cols = rng.integers(0, n, edges), rng.integers(0, n, edges)
    ids = np.flatnonzero(rng.random(n) < 0.8)  # particles of the touched bodies
    keep = np.isin(rows, ids) & np.isin(cols, ids)
    rows, cols = rows[keep], cols[keep]
    got = component_labels(n, ids, rows, cols)
    ref = component_labels_reference(n, ids, rows, cols)
    assert np.array_equal(got, ref)
    assert got.dtype == np.int64 and np.all(got[np.setdiff1d(np.arange(n), ids)] == -1)
    if len(ids):  # numbered by the smallest particle: each label's first appearance is in order
        _, first = np.unique(got[ids], return_index=True)
        assert np.all(np.diff(first) > 0)


def test_a_chain_and_its_cut(taichi_runtime):
    """A chain of 10 links is one piece; without its middle link, two, the smaller ids first."""
    rows, cols = np.arange(9), np.arange(1, 10)
    ids = np.arange(10)
    assert np.array_equal(component_labels(10, ids, rows, cols), np.zeros(10))
    cut = np.arange(9) != 4
    assert np.array_equal(component_labels(10, ids, cols[cut], rows[cut]), np.repeat([0, 1], 5))
