"""Sorted distinct ids by one sort: the same arrays as numpy's set routines."""

import numpy as np
import pytest

from solver.ops.unique import union, unique, unique_rows


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.uint8, bool])
def test_unique_equals_numpy(dtype):
    rng = np.random.default_rng(7)
    for size, hi in [(0, 2), (1, 2), (2, 2), (1000, 5), (50_000, 10**6)]:
        a = rng.integers(0, hi, size=(size, 2)).astype(dtype)
        got, want = unique(a), np.unique(a)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)


def test_unique_of_floats_keeps_numpys_nan_rule():
    a = np.array([2.0, np.nan, 1.0, np.nan, 2.0])
    np.testing.assert_array_equal(unique(a), np.unique(a))
    assert np.isnan(unique(a)).sum() == 1


def test_union_equals_union1d():
    rng = np.random.default_rng(3)
    a, b = rng.integers(0, 500, 300), rng.integers(200, 900, 400)
    np.testing.assert_array_equal(union(a, b), np.union1d(a, b))
    assert union().size == 0


def test_unique_rows_equals_numpy_axis0():
    rng = np.random.default_rng(5)
    E = rng.integers(0, 40, size=(2000, 2))
    np.testing.assert_array_equal(unique_rows(E), np.unique(E, axis=0))
    assert unique_rows(E[:0]).shape == (0, 2)
    neg = np.array([[-1, 2], [-1, 2], [0, 0]])
    np.testing.assert_array_equal(unique_rows(neg), np.unique(neg, axis=0))
