"""Sorted distinct integers and integer pairs, by one sort.

numpy 2.3 and later answer a bare ``np.unique`` of integers from a hash table.
On a few hundred thousand distinct ids (a mesh's edges, a deck's node sets) that
path reads memory at random and is many times slower than sorting the array
once; ``benchmarks/measure_choices.py`` ("distinct ids") has the figures. These
functions sort instead, and give exactly ``np.unique``'s result.
"""

from __future__ import annotations

import numpy as np

__all__ = ["unique", "unique_rows", "union"]


def unique(a: np.ndarray) -> np.ndarray:
    """Sorted distinct values of ``a`` (flattened), as ``np.unique(a)``.

    Parameters
    ----------
    a : array_like
        Any shape. Integer and boolean arrays are sorted here; other dtypes
        (floats with their NaN rule, strings) go to ``np.unique``.

    Returns
    -------
    (u,) array
        Same dtype as ``a``.

    Examples
    --------
    >>> unique(np.array([[3, 1], [3, 2]])).tolist()
    [1, 2, 3]
    """
    a = np.asarray(a)
    if a.dtype.kind not in "iub":
        return np.unique(a)
    s = np.sort(a, axis=None)
    if s.size < 2:
        return s
    keep = np.empty(s.size, dtype=bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def union(*arrays: np.ndarray) -> np.ndarray:
    """Sorted distinct values of every array together, as ``np.union1d`` (any number of arrays)."""
    parts = [np.asarray(x).ravel() for x in arrays]
    if not parts:
        return np.zeros(0, dtype=np.int64)
    return unique(np.concatenate(parts))


def unique_rows(E: np.ndarray) -> np.ndarray:
    """Distinct rows of a two-column array of non-negative ints, sorted, as ``np.unique(E, axis=0)``.

    Parameters
    ----------
    E : (e, 2) int array
        Entries in ``[0, 2**31)``.

    Returns
    -------
    (u, 2) int array
        Same dtype as ``E``.

    Examples
    --------
    >>> unique_rows(np.array([[1, 2], [0, 5], [1, 2]])).tolist()
    [[0, 5], [1, 2]]
    """
    E = np.asarray(E)
    if E.ndim != 2 or E.shape[1] != 2 or E.dtype.kind not in "iu":
        return np.unique(E, axis=0)
    if not E.shape[0]:
        return E.copy()
    n = int(E.max()) + 1
    if int(E.min()) < 0 or n > 2**31:
        return np.unique(E, axis=0)
    key = unique(E[:, 0].astype(np.int64) * n + E[:, 1])
    out = np.empty((key.size, 2), dtype=E.dtype)
    out[:, 0] = key // n
    out[:, 1] = key - out[:, 0].astype(np.int64) * n
    return out
