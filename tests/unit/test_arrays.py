"""core/arrays.py: unique_rows gives what np.unique(rows, axis=0) gives, and cross3 what np.cross gives,
bit for bit."""

import numpy as np
import pytest

from core.arrays import cross3, group_indices, unique_rows


@pytest.mark.parametrize("shape, lo, hi", [((500, 2), 0, 40), ((800, 3), -5, 12), ((300, 2), -1, 3), ((1, 4), 7, 8)])
def test_unique_rows_matches_numpy(shape, lo, hi):
    rows = np.random.default_rng(3).integers(lo, hi, shape)
    want_u, want_inv, want_cnt = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
    got_u, got_inv, got_cnt = unique_rows(rows, return_inverse=True, return_counts=True)
    assert np.array_equal(got_u, want_u) and got_u.dtype == rows.dtype
    assert np.array_equal(got_inv, want_inv.ravel()) and np.array_equal(got_cnt, want_cnt)
    assert np.array_equal(unique_rows(rows), want_u)
    assert np.array_equal(got_u[got_inv], rows)  # every row is its distinct row


def test_float_unique_rows_match_numpy():
    """Float rows (a struck patch's corners) by one lexsort: numpy's rows, order, inverse and counts, with
    repeats and -0.0 (equal to 0.0 for both: either may stand for the two)."""
    rng = np.random.default_rng(5)
    rows = rng.integers(-2, 3, (120, 3)).astype(float) * 0.5
    rows[rng.integers(0, 120, 15)] = -0.0
    for case in (rows, rows[:1], rng.normal(size=(50, 3)), rows[:0]):
        want_u, want_inv, want_cnt = np.unique(case, axis=0, return_inverse=True, return_counts=True)
        got_u, got_inv, got_cnt = unique_rows(case, return_inverse=True, return_counts=True)
        assert got_u.shape == want_u.shape and np.array_equal(got_u, want_u) and got_u.dtype == case.dtype
        assert np.array_equal(got_inv, want_inv.ravel()) and np.array_equal(got_cnt, want_cnt)
    assert len(np.unique(rows, axis=0)) < len(rows)  # the case holds repeats


def test_unique_rows_spans_too_wide_for_one_key_and_empty_input():
    rows = np.array([[0, 0, 0], [2**40, 2**40, 1], [0, 0, 0], [-(2**40), 5, 5]], dtype=np.int64)
    want = np.unique(rows, axis=0, return_inverse=True)
    got = unique_rows(rows, return_inverse=True)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1].ravel())
    empty = np.zeros((0, 2), np.int64)
    uniq, inverse, counts = unique_rows(empty, return_inverse=True, return_counts=True)
    assert uniq.shape == (0, 2) and inverse.shape == (0,) and counts.shape == (0,)


def test_unique_rows_refuses_what_it_does_not_handle():
    with pytest.raises(ValueError, match="integer or float"):
        unique_rows(np.zeros((3, 2), dtype=complex))
    with pytest.raises(ValueError, match=r"\(N, K\)"):
        unique_rows(np.zeros(3, np.int64))


def test_group_indices_equals_a_mask_per_label():
    labels = np.random.default_rng(5).integers(-2, 6, 200)
    groups = group_indices(labels)
    assert [g.tolist() for g in groups] == [np.flatnonzero(labels == b).tolist() for b in np.unique(labels)]
    assert group_indices(np.zeros(0, np.int64)) == []


@pytest.mark.parametrize("shape_a, shape_b, dtype", [
    ((3,), (3,), np.float64), ((200, 3), (200, 3), np.float64), ((3,), (50, 3), np.float64),
    ((20, 3), (3,), np.float64), ((7, 4, 3), (7, 4, 3), np.float32), ((9, 3), (9, 3), np.int64),
    ((3,), (3,), np.float32)])
def test_cross3_is_np_cross_bit_for_bit(shape_a, shape_b, dtype):
    rng = np.random.default_rng(5)
    # magnitudes far apart, so that a product's rounding shows in the difference
    a = (rng.normal(size=shape_a) * 1e3).astype(dtype)
    b = (rng.normal(size=shape_b) * 1e-3).astype(dtype) if dtype != np.int64 else rng.integers(-9, 9, shape_b)
    want, got = np.cross(a, b), cross3(a, b)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()
    lists = [1e3, 2.0 / 3.0, -3.0], [0.1, 0.0, 1.0]  # lists, as the callers pass helper axes
    assert cross3(*lists).tobytes() == np.cross(*lists).tobytes()


def test_cross3_refuses_other_vectors():
    with pytest.raises(ValueError, match="cross3 takes"):
        cross3(np.zeros(2), np.zeros(2))
