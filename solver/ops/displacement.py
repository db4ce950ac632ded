"""The largest vertex displacements of a solve, per role, and whether every position is finite, in one pass.

The pass is a compiled kernel in src/core/geometry.cpp.
"""

from __future__ import annotations

import numpy as np
import tetmorph_core

__all__ = ["max_displacement", "displacement_maxima"]

#: Columns of the per-role maxima: free nodes, handle nodes, fixed nodes.
FREE, HANDLE, FIXED = 0, 1, 2


def _maxima(P: np.ndarray, V: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, bool]:
    n = P.shape[0]
    if not n:
        return np.zeros(3), True
    nch = max(1, min(tetmorph_core.get_num_threads() * 4, n // 4096 or 1))
    best = np.empty((nch, 3))
    bad = np.empty(nch, np.int64)
    tetmorph_core.geometry_max_disp(np.ascontiguousarray(P, dtype=np.float64),
                                    np.ascontiguousarray(V, dtype=np.float64),
                                    np.ascontiguousarray(owner, dtype=np.int64), nch, best, bad)
    if bad.any():
        return np.full(3, np.nan), False
    return np.sqrt(best.max(axis=0)), True


def max_displacement(P: np.ndarray, V: np.ndarray) -> tuple[float, bool]:
    """``max_i |P_i - V_i|`` and whether every entry of ``P`` is finite.

    One compiled pass over both arrays; ``numpy.linalg.norm(P - V, axis=1).max()``
    allocates two temporaries on the way.

    Parameters
    ----------
    P, V : (n, 3) float arrays

    Returns
    -------
    max_displacement : float
        NaN when some position is not finite; 0 for an empty mesh.
    finite : bool

    Examples
    --------
    >>> V = np.zeros((3, 3))
    >>> max_displacement(V + [[0, 0, 0], [3, 4, 0], [1, 0, 0]], V)
    (5.0, True)
    >>> max_displacement(np.array([[np.nan, 0, 0]]), np.zeros((1, 3)))
    (nan, False)
    """
    m, finite = _maxima(P, V, np.zeros(0, np.int64))
    return float(m.max()), finite


def displacement_maxima(P: np.ndarray, V: np.ndarray, owner: np.ndarray) -> tuple[float, float, float, bool]:
    """The largest displacement of all nodes, of the handles' nodes and of the free nodes, in one pass.

    A morph that moves a free node further than any handle surprises its
    user (a wall pushed out by a bore moved in): the REPORT states both.

    Parameters
    ----------
    P, V : (n, 3) float arrays
        Solved and rest positions.
    owner : (n,) int array
        Each node's role: ``h >= 0`` in handle ``h``, ``-2`` fixed, ``-1`` free
        (:attr:`~solver.deform.constraint_set.ConstraintSet.owner`).

    Returns
    -------
    overall, handles, free : float
        NaN when some position is not finite; 0 where no node has the role.
    finite : bool

    Examples
    --------
    >>> V = np.zeros((3, 3))
    >>> displacement_maxima(V + [[0, 0, 1], [3, 4, 0], [0, 2, 0]], V, np.array([-2, 0, -1]))
    (5.0, 5.0, 2.0, True)
    """
    m, finite = _maxima(P, V, owner)
    return float(m.max()), float(m[HANDLE]), float(m[FREE]), finite
