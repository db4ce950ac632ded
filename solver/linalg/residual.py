"""Residuals of a sparse system for blocks of right-hand sides, with their largest row norms, in one pass.

A mixed-precision interior solve (:class:`~solver.deform.positions.SplitPositions`)
checks its single-precision solution ``X`` of ``A X = B`` in double precision:
``R = B - A X`` and, per block of ``width`` columns (one position array), the
largest row norm of ``R`` and of ``X``. With many blocks (a DOE's stacked rows)
this is a sparse matrix times a wide dense matrix, which scipy computes on one
thread, followed by two norm passes over strided column slices; the kernel
here does all of it in one parallel sweep over the rows.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

__all__ = ["block_residual", "coupled_residual_norms", "corrected"]


@numba.njit(inline="always", cache=True, nogil=True)
def _axpy_row(indptr, indices, data, X, i, sign, acc):  # pragma: no cover - compiled
    """``acc += sign * A[i] X``: one sparse row times the dense block."""
    m = acc.shape[0]
    for p in range(indptr[i], indptr[i + 1]):
        a = sign * data[p]
        k = indices[p]
        for j in range(m):
            acc[j] += a * X[k, j]


@numba.njit(inline="always", cache=True, nogil=True)
def _tally_row(acc, X, i, width, c, store, R, rmax, xmax):  # pragma: no cover - compiled
    """Row ``i``'s residual ``acc`` (stored in ``R`` if asked): the largest squared norms per block so far."""
    for b in range(acc.shape[0] // width):
        r2 = 0.0
        x2 = 0.0
        for q in range(b * width, (b + 1) * width):
            if store:
                R[i, q] = acc[q]
            r2 += acc[q] * acc[q]
            x2 += X[i, q] * X[i, q]
        if not r2 <= rmax[c, b]:  # NaN propagates: a NaN row is the largest
            rmax[c, b] = r2
        if not x2 <= xmax[c, b]:
            xmax[c, b] = x2


@numba.njit(parallel=True, cache=True, nogil=True)
def _residual_kernel(indptr, indices, data, B, X, width, store, R, rmax, xmax):  # pragma: no cover - compiled
    n, m = B.shape
    nch = rmax.shape[0]
    for c in numba.prange(nch):
        acc = np.empty(m)
        for i in range(c * n // nch, (c + 1) * n // nch):
            for j in range(m):
                acc[j] = B[i, j]
            _axpy_row(indptr, indices, data, X, i, -1.0, acc)
            _tally_row(acc, X, i, width, c, store, R, rmax, xmax)


@numba.njit(parallel=True, cache=True, nogil=True)
def _coupled_residual_kernel(ai, aj, ax, mi, mj, mx, r0, D, X, width, R, rmax, xmax):  # pragma: no cover - compiled
    """:func:`_residual_kernel` norms for ``B = r0 + M D`` (``r0`` in every block), ``B`` never stored."""
    n, m = X.shape[0], D.shape[1]
    nch = rmax.shape[0]
    for c in numba.prange(nch):
        acc = np.empty(m)
        for i in range(c * n // nch, (c + 1) * n // nch):
            for j in range(m):
                acc[j] = r0[i, j % width]
            _axpy_row(mi, mj, mx, D, i, 1.0, acc)
            _axpy_row(ai, aj, ax, X, i, -1.0, acc)
            _tally_row(acc, X, i, width, c, False, R, rmax, xmax)


@numba.njit(parallel=True, cache=True, nogil=True, error_model="numpy")
def _residual3_kernel(indptr, indices, data, B, X, store, R, rmax, xmax):  # pragma: no cover - compiled
    """:func:`_residual_kernel` for one block of three columns (one update), with the sums in registers."""
    n = B.shape[0]
    nch = rmax.shape[0]
    for c in numba.prange(nch):
        lo = c * n // nch
        hi = (c + 1) * n // nch
        rm = 0.0
        xm = 0.0
        for i in range(lo, hi):
            a0 = B[i, 0]
            a1 = B[i, 1]
            a2 = B[i, 2]
            for p in range(indptr[i], indptr[i + 1]):
                v = data[p]
                k = indices[p]
                a0 -= v * X[k, 0]
                a1 -= v * X[k, 1]
                a2 -= v * X[k, 2]
            if store:
                R[i, 0] = a0
                R[i, 1] = a1
                R[i, 2] = a2
            r2 = a0 * a0 + a1 * a1 + a2 * a2
            x2 = X[i, 0] * X[i, 0] + X[i, 1] * X[i, 1] + X[i, 2] * X[i, 2]
            if not r2 <= rm:  # NaN propagates: a NaN row is the largest
                rm = r2
            if not x2 <= xm:
                xm = x2
        rmax[c, 0] = rm
        xmax[c, 0] = xm


@numba.njit(parallel=True, cache=True, nogil=True)
def _subtract_rows(Q, rows, X, col):  # pragma: no cover - compiled
    w = Q.shape[1]
    for r in numba.prange(rows.size):
        i = rows[r]
        for a in range(w):
            Q[i, a] -= X[r, col + a]


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
    _subtract_rows(Q, np.ascontiguousarray(rows, dtype=np.int64), _values(X), col)
    return Q


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
    nch = max(1, min(numba.get_num_threads(), n))
    rmax = np.zeros((nch, m // width))
    xmax = np.zeros((nch, m // width))
    if m == 3 and width == 3:
        _residual3_kernel(A.indptr, A.indices, np.asarray(A.data, np.float64), Bc, Xc, store, R, rmax, xmax)
    else:
        _residual_kernel(A.indptr, A.indices, np.asarray(A.data, np.float64), Bc, Xc, width, store, R, rmax, xmax)
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
    nch = max(1, min(numba.get_num_threads(), n))
    rmax = np.zeros((nch, m // width))
    xmax = np.zeros((nch, m // width))
    _coupled_residual_kernel(A.indptr, A.indices, np.asarray(A.data, np.float64), M.indptr, M.indices,
                             np.asarray(M.data, np.float64), np.ascontiguousarray(r0, dtype=np.float64),
                             np.ascontiguousarray(D, dtype=np.float64), _values(X), width, np.empty((0, 0)), rmax,
                             xmax)
    return np.sqrt(rmax.max(axis=0)), np.sqrt(xmax.max(axis=0))
