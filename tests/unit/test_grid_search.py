"""geometry/grid_search.py against scipy, the engine it stands in for: pairs within a distance (a
radius each or one for all, clustered and spread points, points on a cell's edge, empty inputs) and
the components of a graph."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from geometry.grid_search import components, pairs_within


def _scipy_pairs(q, d, r):
    hits = cKDTree(d).query_ball_point(q, r)
    pairs = sorted((i, j) for i, h in enumerate(hits) for j in h)
    return [p[0] for p in pairs], [p[1] for p in pairs]


@pytest.mark.parametrize("seed", range(6))
def test_pairs_are_scipys(seed):
    rng = np.random.default_rng(seed)
    d = np.concatenate([rng.random((300, 3)), 0.01 * rng.random((100, 3)) + 0.5])  # spread and clustered
    q = np.concatenate([rng.random((200, 3)), d[:20]])  # some on data points
    r = rng.random(len(q)) * 0.25 if seed % 2 else 0.12
    i, j = pairs_within(q, d, r)
    si, sj = _scipy_pairs(q, d, r)
    assert len(i) > 100
    np.testing.assert_array_equal(i, si)
    np.testing.assert_array_equal(j, sj)


def test_points_on_a_grid_and_edge_cases():
    g = np.stack(np.meshgrid(*[np.arange(5.0)] * 3, indexing="ij"), -1).reshape(-1, 3)  # distances 1 exactly
    i, j = pairs_within(g, g, 1.0)
    si, sj = _scipy_pairs(g, g, 1.0)
    np.testing.assert_array_equal(i, si)
    np.testing.assert_array_equal(j, sj)
    assert all(len(a) == 0 for a in pairs_within(g[:0], g, 1.0) + pairs_within(g, g[:0], 1.0))
    i, j = pairs_within(g, g, 0.0)  # only a point itself
    np.testing.assert_array_equal(i, np.arange(len(g)))
    np.testing.assert_array_equal(j, np.arange(len(g)))


@pytest.mark.parametrize("seed", range(4))
def test_components_are_scipys(seed):
    rng = np.random.default_rng(seed)
    n = 400
    a, b = rng.integers(0, n, 300), rng.integers(0, n, 300)
    count, label = components(n, a, b)
    ref_count, ref = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)), directed=False)
    assert count == ref_count
    # the same partition: a one-to-one map between the two labellings
    pairs = np.unique(np.stack([label, ref], 1), axis=0)
    assert len(pairs) == count == len(np.unique(pairs[:, 0])) == len(np.unique(pairs[:, 1]))
    first = np.unique(label, return_index=True)[1]
    assert np.all(np.diff(first) > 0)  # labels in the order of each component's smallest node


def test_a_kept_grid_answers_queries_outside_its_box_and_refuses_a_larger_radius():
    from geometry.grid_search import PointGrid

    rng = np.random.default_rng(7)
    d = rng.random((500, 3))
    grid = PointGrid(d, 0.2)
    for shift in (-1.1, -0.15, 0.0, 0.9, 1.05):
        q = rng.random((100, 3)) * 0.5 + shift  # partly or wholly outside the data's box
        i, j = grid.pairs(q, 0.15)
        si, sj = _scipy_pairs(q, d, 0.15)
        np.testing.assert_array_equal(i, si)
        np.testing.assert_array_equal(j, sj)
    with pytest.raises(ValueError, match="above the grid's cell"):
        grid.pairs(d[:3], 0.3)
