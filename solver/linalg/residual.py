"""Residuals of a sparse system for blocks of right-hand sides, with their largest row norms, in one pass.

A mixed-precision interior solve (:class:`~solver.deform.positions.SplitPositions`)
checks its single-precision solution ``X`` of ``A X = B`` in double precision:
``R = B - A X`` and, per block of ``width`` columns (one position array), the
largest row norm of ``R`` and of ``X``. With many blocks (a DOE's stacked rows)
this is a sparse matrix times a wide dense matrix, which scipy computes on one
thread, followed by two norm passes over strided column slices; the kernel
here does all of it in one parallel sweep over the rows (compiled kernels in
src/core/products.cpp: ``products_residual``, ``products_residual3``,
``products_coupled_residual``, ``products_subtract_rows``; float32 or float64 ``X``,
int32 or int64 indices).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import tetmorph_core

__all__ = ["block_residual", "coupled_residual_norms", "corrected"]


def corrected(P: np.ndarray, rows: np.ndarray, X: np.ndarray, col: int, overwrite: bool = False) -> np.ndarray:
    """A copy of ``P`` with ``P[rows] - X[:, col:col + w]`` in ``rows`` (``w = P.shape[1]``).

    numpy's fancy-indexed ``Q[rows] -= X[:, a:b]`` gathers, subtracts and
    scatters through temporaries; the kernel does it in one pass over the rows.

    Parameters
    ----------
    P : (n, w) float array
    rows : (f,) int array
        Distinct rows of ``P``.
    X : (f, m) float array
    col : int
        First column of ``X`` to subtract.
    overwrite : bool
        Subtract in ``P`` itself when it is a C-ordered float64 array (the caller owns it).

    Returns
    -------
    (n, w) float64 array

    Examples
    --------
    >>> corrected(np.zeros((3, 1)), np.array([2, 0]), np.array([[1.0, 5.0], [2.0, 6.0]]), 1).ravel().tolist()
    [-6.0, 0.0, -5.0]
    """
    if X.shape[0] != rows.size or col < 0 or col + P.shape[1] > X.shape[1]:
        raise ValueError(f"corrected: P {P.shape}, {rows.size} rows, X {X.shape}, column {col} do not agree")
    own = overwrite and P.dtype == np.float64 and P.flags.c_contiguous and P.flags.writeable
    Q = P if own else np.array(P, dtype=np.float64, order="C")
    tetmorph_core.products_subtract_rows(Q, np.ascontiguousarray(rows, dtype=np.int64), _values(X), col)
    return Q


def _csr(A: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A``'s index arrays in one index type the kernels take (int32 or int64), and its values as float64."""
    ip, ix = A.indptr, A.indices
    if ip.dtype != ix.dtype or ip.dtype not in (np.int32, np.int64):
        ip, ix = ip.astype(np.int64), ix.astype(np.int64)
    return ip, ix, np.ascontiguousarray(A.data, dtype=np.float64)


def _values(X: np.ndarray) -> np.ndarray:
    """``X`` C-ordered, float32 kept as float32 (the kernels widen it exactly), anything else as float64."""
    return np.ascontiguousarray(X, dtype=np.float32 if X.dtype == np.float32 else np.float64)


def block_residual(A: sp.csr_matrix, B: np.ndarray, X: np.ndarray,
                   width: int, store: bool = True) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
    """``R = B - A X`` with the largest row norms of ``R`` and ``X`` per block of columns.

    Parameters
    ----------
    A : (n, n) csr matrix
    B : (n, m) float array
    X : (n, m) float array
        Read as float32 when it is float32 (a single-precision solution), else as float64.
    width : int
        Columns per block; ``m`` must be a multiple of it.
    store : bool
        Return ``R`` (else None: only the norms, without writing an (n, m) array).

    Returns
    -------
    R : (n, m) float64 array or None
    r : (m // width,) float array
        ``max_i |R[i, block]|``.
    x : (m // width,) float array
        ``max_i |X[i, block]|``.

    Examples
    --------
    >>> A = sp.csr_matrix(np.array([[2.0, -1.0], [-1.0, 2.0]]))
    >>> X = np.array([[1.0, 0.0], [1.0, 1.0]])
    >>> R, r, x = block_residual(A, A @ X + [[0.0, 3.0], [0.0, 4.0]], X, 1)
    >>> float(np.abs(R - [[0, 3], [0, 4]]).max()), r.tolist(), x.tolist()
    (0.0, [0.0, 4.0], [1.0, 1.0])
    """
    n, m = B.shape
    if A.shape != (n, X.shape[0]) or X.shape != B.shape or width < 1 or m % width:
        raise ValueError(f"block_residual: A {A.shape}, B {B.shape}, X {X.shape}, width {width} do not agree")
    A = A.tocsr() if not sp.isspmatrix_csr(A) else A
    Bc = np.ascontiguousarray(B, dtype=np.float64)
    Xc = _values(X)  # a float32 solution as it is: exact when widened, half the bytes to gather
    R = np.empty((n, m) if store else (0, 0))
    nch = max(1, min(tetmorph_core.get_num_threads(), n))
    rmax = np.zeros((nch, m // width))
    xmax = np.zeros((nch, m // width))
    if m == 3 and width == 3:
        tetmorph_core.products_residual3(*_csr(A), Bc, Xc, store, R, rmax, xmax)
    else:
        tetmorph_core.products_residual(*_csr(A), Bc, Xc, width, store, R, rmax, xmax)
    return (R if store else None), np.sqrt(rmax.max(axis=0)), np.sqrt(xmax.max(axis=0))


def coupled_residual_norms(A: sp.csr_matrix, M: sp.csr_matrix, r0: np.ndarray, D: np.ndarray, X: np.ndarray,
                           width: int) -> tuple[np.ndarray, np.ndarray]:
    """The norms of :func:`block_residual` for ``B = r0 + M D`` (``r0`` added to every block), ``B`` never formed.

    The stacked interior check of a solve that never needed its right-hand side
    (:meth:`~solver.deform.positions.SplitPositions.interior_solve_many` through a
    column basis): one pass over the rows of ``A`` and ``M`` instead of writing
    and reading an (n, m) array (110 MB for 96 columns at 1M tets).

    Parameters
    ----------
    A : (n, n) csr matrix
    M : (n, c) csr matrix
    r0 : (n, width) float array
    D : (c, m) float array
    X : (n, m) float array
        Read as float32 when it is float32, else as float64.
    width : int
        Columns per block; ``m`` must be a multiple of it.

    Returns
    -------
    r : (m // width,) float array
        ``max_i |B[i, block] - (A X)[i, block]|``.
    x : (m // width,) float array
        ``max_i |X[i, block]|``.

    Examples
    --------
    >>> A, M = sp.csr_matrix(np.eye(2)), sp.csr_matrix(np.array([[1.0], [2.0]]))
    >>> X = np.array([[1.0, 3.0], [2.0, 5.0]])
    >>> r, x = coupled_residual_norms(A, M, np.zeros((2, 1)), np.array([[1.0, 3.0]]), X, 1)
    >>> r.tolist(), x.tolist()
    ([0.0, 1.0], [2.0, 5.0])
    """
    n, m = X.shape
    if (A.shape != (n, n) or M.shape != (n, D.shape[0]) or D.shape[1] != m or r0.shape != (n, width)
            or width < 1 or m % width):
        raise ValueError(f"coupled_residual_norms: A {A.shape}, M {M.shape}, r0 {r0.shape}, D {D.shape}, "
                         f"X {X.shape}, width {width} do not agree")
    A = A.tocsr() if not sp.isspmatrix_csr(A) else A
    M = M.tocsr() if not sp.isspmatrix_csr(M) else M
    nch = max(1, min(tetmorph_core.get_num_threads(), n))
    rmax = np.zeros((nch, m // width))
    xmax = np.zeros((nch, m // width))
    tetmorph_core.products_coupled_residual(*_csr(A), *_csr(M), np.ascontiguousarray(r0, dtype=np.float64),
                                            np.ascontiguousarray(D, dtype=np.float64), _values(X), width, rmax, xmax)
    return np.sqrt(rmax.max(axis=0)), np.sqrt(xmax.max(axis=0))
