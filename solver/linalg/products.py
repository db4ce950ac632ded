"""Sparse products of one update's narrow blocks, fused and threaded.

An interactive update multiplies sparse matrices with blocks of three
columns several times (the least-squares gradient of the boundary system,
the interior's right-hand side). scipy computes each product on one thread
into a new array, and the surrounding subtractions and gathers are further
passes; at the 107k-tet bracket that is a few tenths of a millisecond per
update out of about five. The kernels here do each in one parallel pass over
the rows, with the same sums in the same order per row (results equal
scipy's to round-off): compiled kernels in src/core/products.cpp (``products_*``,
for int32 and int64 indices).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import tetmorph_core

__all__ = ["gradient", "product", "combination", "shifted_product", "offset_product", "stacked_differences"]


def _f64(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


def _csr(M: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M``'s index arrays in one index type the kernels take (int32 or int64), and its values as float64."""
    ip, ix = M.indptr, M.indices
    if ip.dtype != ix.dtype or ip.dtype not in (np.int32, np.int64):
        ip, ix = ip.astype(np.int64), ix.astype(np.int64)
    return ip, ix, _f64(M.data)


def gradient(A: sp.csr_matrix, At: sp.csr_matrix, c: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``A^T (c - A x)``, the least-squares gradient, for (N, k) ``x`` and (l, k) ``c``.

    Parameters
    ----------
    A : (l, N) csr matrix
    At : (N, l) csr matrix
        ``A^T`` in CSR (its rows are ``A``'s columns).
    c : (l, k) or (b, l, w) array
        The right-hand sides; stacked as ``b`` blocks of ``w`` columns (``k = b w``)
        they are read in place (no (l, k) copy is made of them).
    x : (N, k) array

    Returns
    -------
    (N, k) float64 array

    Examples
    --------
    >>> A = sp.csr_matrix(np.array([[1.0, 2.0], [0.0, 1.0]]))
    >>> gradient(A, sp.csr_matrix(A.T), np.array([[1.0], [1.0]]), np.zeros((2, 1))).ravel().tolist()
    [1.0, 3.0]
    """
    c, x = _f64(c), _f64(x)
    stacked = c.ndim == 3
    rows, cols = (c.shape[1], c.shape[0] * c.shape[2]) if stacked else (c.shape[0], c.shape[1] if c.ndim == 2 else -1)
    if A.shape != (rows, x.shape[0]) or At.shape != (A.shape[1], A.shape[0]) or x.ndim != 2 or cols != x.shape[1]:
        raise ValueError(f"gradient: A {A.shape}, At {At.shape}, c {c.shape}, x {x.shape} do not agree")
    t = np.empty((rows, cols))
    tetmorph_core.products_residual_rows_stacked(*_csr(A), c if stacked else c[None], x, t)
    out = np.empty(x.shape)
    tetmorph_core.products_product_rows(*_csr(At), t, out)
    return out


def shifted_product(M: sp.csr_matrix, cols: np.ndarray, P: np.ndarray, rest: np.ndarray,
                    r0: np.ndarray) -> np.ndarray:
    """``r0 + M (P[cols] - rest)`` without forming ``P[cols] - rest``.

    Parameters
    ----------
    M : (f, c) csr matrix
    cols : (c,) int array
        Rows of ``P`` that ``M``'s columns stand for.
    P : (n, k) array
    rest : (c, k) array
    r0 : (f, k) array

    Returns
    -------
    (f, k) float64 array

    Examples
    --------
    >>> M = sp.csr_matrix(np.array([[1.0, -1.0]]))
    >>> P = np.array([[5.0], [1.0], [3.0]])
    >>> shifted_product(M, np.array([2, 0]), P, np.array([[1.0], [1.0]]), np.array([[0.5]])).ravel().tolist()
    [-1.5]
    """
    P, rest, r0 = _f64(P), _f64(rest), _f64(r0)
    if M.shape != (r0.shape[0], cols.size) or rest.shape != (cols.size, P.shape[1]) or r0.shape[1] != P.shape[1]:
        raise ValueError(f"shifted_product: M {M.shape}, {cols.size} cols, P {P.shape}, rest {rest.shape}, "
                         f"r0 {r0.shape} do not agree")
    out = np.empty(r0.shape)
    tetmorph_core.products_shifted_rows(*_csr(M), np.ascontiguousarray(cols, dtype=np.int64), P, rest, r0, out)
    return out


def product(M: sp.csr_matrix, X: np.ndarray) -> np.ndarray:
    """``M X`` in one threaded pass over the rows (scipy's product runs on one thread).

    Parameters
    ----------
    M : (f, c) csr matrix
    X : (c, m) array

    Returns
    -------
    (f, m) float64 array

    Examples
    --------
    >>> product(sp.csr_matrix(np.array([[1.0, 2.0]])), np.array([[1.0, 0.0], [1.0, 1.0]])).tolist()
    [[3.0, 2.0]]
    """
    X = _f64(X)
    if X.ndim != 2 or M.shape[1] != X.shape[0]:
        raise ValueError(f"product: M {M.shape}, X {X.shape} do not agree")
    out = np.empty((M.shape[0], X.shape[1]))
    tetmorph_core.products_product_rows(*_csr(M), X, out)
    return out


def combination(W: np.ndarray, C: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """``W C`` summed in double precision and stored as ``dtype`` (float32 or float64).

    For a tall ``W`` of few columns (solutions of a column basis) and a small
    ``C`` (their coefficients): one threaded pass that reads ``W`` as it is
    (float32 solutions are widened exactly) and writes the result once.

    Parameters
    ----------
    W : (f, r) float32 or float64 array
    C : (r, m) float array
    dtype : {numpy.float64, numpy.float32}

    Returns
    -------
    (f, m) array of ``dtype``

    Examples
    --------
    >>> combination(np.array([[1.0, 2.0]], np.float32), np.array([[1.0, 0.5], [1.0, 0.25]])).tolist()
    [[3.0, 1.0]]
    """
    if W.ndim != 2 or C.ndim != 2 or W.shape[1] != C.shape[0]:
        raise ValueError(f"combination: W {W.shape}, C {C.shape} do not agree")
    Wc = np.ascontiguousarray(W, dtype=np.float32 if W.dtype == np.float32 else np.float64)
    out: np.ndarray = np.empty((W.shape[0], C.shape[1]), dtype=np.dtype(dtype))
    tetmorph_core.products_combine_rows(Wc, _f64(C), out)
    return out


def offset_product(M: sp.csr_matrix, D: np.ndarray, r0: np.ndarray) -> np.ndarray:
    """``M D`` with ``r0`` added to every block of ``r0``'s width: the stacked interior right-hand sides.

    Parameters
    ----------
    M : (f, c) csr matrix
    D : (c, w k) array
    r0 : (f, w) array

    Returns
    -------
    (f, w k) float64 array

    Examples
    --------
    >>> M = sp.csr_matrix(np.array([[1.0, 2.0]]))
    >>> offset_product(M, np.array([[1.0, 0.0], [1.0, 1.0]]), np.array([[0.5]])).tolist()
    [[3.5, 2.5]]
    """
    D, r0 = _f64(D), _f64(r0)
    if M.shape != (r0.shape[0], D.shape[0]) or r0.shape[1] < 1 or D.shape[1] % r0.shape[1]:
        raise ValueError(f"offset_product: M {M.shape}, D {D.shape}, r0 {r0.shape} do not agree")
    out = np.empty((M.shape[0], D.shape[1]))
    tetmorph_core.products_offset_rows(*_csr(M), D, r0, out)
    return out


def stacked_differences(Ps: list[np.ndarray], cols: np.ndarray, rest: np.ndarray, order: str = "C") -> np.ndarray:
    """``[P_1[cols] - rest, P_2[cols] - rest, ...]`` side by side: (c, w k) for k arrays ``P_j`` (n, w).

    ``order="F"`` writes the block column-major (LAPACK's layout: a QR then copies it without transposing).

    Examples
    --------
    >>> P = np.array([[1.0], [2.0], [4.0]])
    >>> stacked_differences([P, 2 * P], np.array([2, 0]), np.array([[1.0], [1.0]])).tolist()
    [[3.0, 7.0], [0.0, 1.0]]
    """
    rest = _f64(rest)
    c = np.ascontiguousarray(cols, dtype=np.int64)
    w = rest.shape[1]
    if rest.shape[0] != c.size or any(P.ndim != 2 or P.shape[1] != w for P in Ps):
        raise ValueError(f"stacked_differences: {c.size} cols, rest {rest.shape}, arrays "
                         f"{[P.shape for P in Ps][:3]} do not agree")
    D = np.empty((c.size, w * len(Ps)), order="F" if order == "F" else "C")
    tetmorph_core.products_stacked_differences([_f64(P) for P in Ps], c, rest, D)
    return D
