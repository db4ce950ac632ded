"""A few columns that span many: the numerical range of a block of right-hand sides.

A DOE block stacks the boundary displacements of its variants side by side,
three columns per variant. They are smooth functions of a handful of shape
parameters, so the block has far fewer independent columns than it has
columns: on the 1M-tet bracket with four shapes, 16 variants (48 columns)
span 13 directions to 1e-10 and 20 to 1e-14 of each column's norm. A
linear solve then needs only those directions, and every variant is a
combination of their solutions.

:func:`column_basis` finds them with a Householder QR of the column-scaled
block followed by an SVD of its small triangular factor (LAPACK's
``geqrf`` and ``gesdd``: backward stable, so singular values far below the
largest are resolved, unlike an eigen-decomposition of ``D^T D``, which
loses everything below about 1e-8 of the largest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ColumnBasis", "column_basis"]


@dataclass(frozen=True, eq=False)
class ColumnBasis:
    """``D ~= basis @ coefficients`` with a per-column relative error bound.

    Attributes
    ----------
    basis : (c, r) float64 array
        Combinations of the columns of ``D`` (orthogonal, column ``i`` of norm
        ``sigma_i`` of the scaled block).
    coefficients : (r, m) float64 array
    error : float
        Bound on ``|D[:, j] - basis @ coefficients[:, j]| / |D[:, j]|`` (2-norms)
        for every column: the largest dropped singular value of the scaled block.
    """

    basis: np.ndarray
    coefficients: np.ndarray
    error: float

    @property
    def rank(self) -> int:
        """Columns kept."""
        return int(self.basis.shape[1])


def column_basis(D: np.ndarray, tol: float, scale: np.ndarray | None = None) -> ColumnBasis:
    """The directions of ``D`` that matter to a relative accuracy ``tol`` per column.

    Each column is scaled to unit norm (a variant moved a little is
    approximated as well, relative to its own size, as one moved a lot);
    the scaled block ``D_s = Q R`` by QR, ``R = U S V^T`` by SVD; the
    directions are ``D_s V_r`` for the singular values above ``tol``, and
    ``D[:, j] ~= D_s V_r (V_r^T e_j) |D[:, j]|``. Dropping the rest moves
    column ``j`` by at most ``S[r] |D[:, j]|``: the reported ``error``.
    A column-major ``D`` spares the transposing copy before LAPACK's.

    Parameters
    ----------
    D : (c, m) float array
    tol : float
        Relative accuracy per column, in (0, 1).
    scale : (m,) float array, optional
        What each column's accuracy is relative to (default its own norm): the
        norms of the block whose remainder ``D`` is, after a projection.

    Returns
    -------
    ColumnBasis

    Raises
    ------
    ValueError
        ``D`` not a 2-d array of finite values, or ``tol`` outside (0, 1).

    Examples
    --------
    >>> D = np.outer([1.0, 2.0, 3.0], [1.0, -2.0, 0.5, 0.0])
    >>> b = column_basis(D, 1e-12)
    >>> b.rank, bool(np.allclose(b.basis @ b.coefficients, D))
    (1, True)
    """
    D = np.asarray(D, dtype=np.float64)
    if D.ndim != 2:
        raise ValueError(f"column_basis: D must be a 2-d array, got shape {D.shape}")
    if not 0.0 < tol < 1.0:
        raise ValueError(f"column_basis: tol must be in (0, 1), got {tol!r}")
    c, m = D.shape
    if c == 0 or m == 0:
        return ColumnBasis(np.zeros((c, 0)), np.zeros((0, m)), 0.0)
    # D S^-1 = Q (R S^-1): Householder QR is backward stable column by column, so scaling R's
    # columns equals factoring the scaled block; |R[:, j]| = |D[:, j]| gives the scales
    R = np.linalg.qr(D if D.flags.f_contiguous else np.asfortranarray(D), mode="r")  # (min(c, m), m), no Q
    if not np.isfinite(R).all():  # a NaN or an infinity anywhere in D reaches R
        raise ValueError("column_basis: D must be finite")
    norms = np.sqrt(np.einsum("ij,ij->j", R, R))
    if not norms.any():
        return ColumnBasis(np.zeros((c, 0)), np.zeros((0, m)), 0.0)
    if scale is not None:
        norms = np.asarray(scale, dtype=np.float64)
        if norms.shape != (m,) or not np.isfinite(norms).all():
            raise ValueError(f"column_basis: scale must be {m} finite norms, got shape {norms.shape}")
    scale = np.where(norms > 0.0, norms, 1.0)
    _, s, Vt = np.linalg.svd(R / scale)
    r = int(np.count_nonzero(s > tol))
    error = float(s[r]) if r < s.size else 0.0
    V = Vt[:r]
    return ColumnBasis(D @ (V / scale).T, V * scale, error)
