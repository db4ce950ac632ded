"""Equality-constrained quadratic minimisation: three exact methods behind one protocol.

Solves ::

    min_x  1/2 x^T H x - g^T x     subject to   C x = d            (ECLS eq. 13)

for ``x`` of shape (N, k) (k right-hand sides sharing ``H`` and ``C``), where
``H = A^T A`` (least squares, ``g = A^T c``) or a given symmetric positive
semi-definite ``H`` (the harmonic rotation system). ``H`` need only be
definite on the null space of ``C``.

Methods (:data:`METHODS`, one class each, built by :func:`constrained_solver`):

:class:`NullSpaceSolver` (``null_space``)
    ECLS §3.2, eq. (14)-(21): ``C^T = Q R``, ``x = Q1 R1^{-T} d + Q2 z``, and
    ``z`` from the reduced normal equations ``(Q2^T H Q2) z = Q2^T (g - H x_p)``.
    The QR factorizations are done **per connected component** of the
    constraint graph (:mod:`solver.linalg.rank`), so ``Q2`` is block
    diagonal: a positional constraint is a 1x1 block, a sliding node a 3x3
    block, a rigid feature one block per coordinate. The reduced matrix keeps
    the sparsity of ``H`` except inside a component.
:class:`KKTSolver` (``kkt``)
    Lagrange multipliers: ``[[H, C^T], [C, 0]] [x; lambda] = [g; d]`` with a
    sparse symmetric indefinite factorization (:func:`~solver.linalg.factorization.ldl`).
    ``C`` and ``d`` are scaled so both blocks have comparable magnitude.
:class:`PenaltySolver` (``penalty``)
    ``(H + beta^2 C^T C) x = g + beta^2 C^T d`` (Masuda & Ogawa eq. 4.2); the
    constraints hold only approximately, and the residual is reported.

Every method uses only the rows the rank analysis keeps. Each solver owns one
factorization, is built once and never mutated: ``solve`` only
back-substitutes, so one instance may serve concurrent solves.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
import scipy.sparse as sp

from . import factorization as fz
from . import products
from .rank import RANK_TOL, RankAnalysis, rank_analysis

__all__ = ["ConstrainedSolver", "NullSpaceSolver", "KKTSolver", "PenaltySolver", "constrained_solver", "METHODS",
           "RankAnalysis", "rank_analysis"]


class ConstrainedSolver(Protocol):
    """What every constrained-quadratic method offers."""

    C: sp.csr_matrix
    kept: np.ndarray
    ra: RankAnalysis
    factorizations: int

    @property
    def nbytes(self) -> int:
        """Bytes held by the factor and the matrices."""
        ...

    def gradient(self, x: np.ndarray, c: np.ndarray | None) -> np.ndarray:
        """``g - H x``."""
        ...

    def start(self, x0: np.ndarray, d: np.ndarray) -> np.ndarray:
        """A starting point for :meth:`step`."""
        ...

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Correction ``dx`` for gradient residual ``r = g - H x`` at ``x``."""
        ...

    def solve(self, x0: np.ndarray, d: np.ndarray, c: np.ndarray | None, refine: int = 1) -> np.ndarray:
        """Solve from ``x0`` with ``refine`` refinement steps."""
        ...

    def residuals(self, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``|C x - d|`` per row."""
        ...


def _nbytes(M: sp.spmatrix) -> int:
    M = sp.csr_matrix(M)
    return int(M.data.nbytes + M.indices.nbytes + M.indptr.nbytes)


class _Quadratic:
    """The objective and the constraint rows shared by every method."""

    def __init__(self, C: sp.spmatrix, A: sp.spmatrix | None, H: sp.spmatrix | None,
                 analysis: RankAnalysis | None, rank_tol: float) -> None:
        if (A is None) == (H is None):
            raise ValueError("give exactly one of A and H")
        self.C = sp.csr_matrix(C, dtype=np.float64)
        self.A = None if A is None else sp.csr_matrix(A)
        self.At = None if self.A is None else sp.csr_matrix(self.A.T)
        self.H = None if H is None else sp.csr_matrix(H)
        self.N = self.C.shape[1]
        self.ra = analysis if analysis is not None else rank_analysis(self.C, rank_tol)
        self.kept = self.ra.kept
        self.Ck = self.C[np.flatnonzero(self.kept)]
        self.factorizations = 0

    def _full_H(self) -> sp.csr_matrix:
        if self.H is not None:
            return self.H
        assert self.At is not None and self.A is not None
        return sp.csr_matrix(self.At @ self.A)

    def _matrix_bytes(self) -> int:
        total = _nbytes(self.C)
        for M in (self.A, self.At, self.H):
            if M is not None:
                total += _nbytes(M)
        return total

    def gradient(self, x: np.ndarray, c: np.ndarray | None) -> np.ndarray:
        """``g - H x``: with ``A``, ``A^T (c - A x)``; with ``H``, ``-H x`` (``c`` ignored)."""
        if self.A is not None:
            assert self.At is not None and c is not None
            return products.gradient(self.A, self.At, c, x)  # one threaded pass per product
        assert self.H is not None
        return -(self.H @ x)

    def start(self, x0: np.ndarray, d: np.ndarray) -> np.ndarray:
        """A starting point: ``x0`` (methods other than the null space)."""
        return x0.copy()

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def solve(self, x0: np.ndarray, d: np.ndarray, c: np.ndarray | None, refine: int = 1) -> np.ndarray:
        """Solve from ``x0`` (the rest state: residual form) with ``refine`` refinement steps.

        Parameters
        ----------
        x0 : (N, k) array
        d : (m, k) array
            Targets of every row (dropped rows are ignored).
        c : (l, k) array, (b, l, w) array or None
            Least-squares right-hand side when built from ``A`` (stacked: ``b`` blocks
            of ``w`` columns, ``k = b w``, read in place by the gradient).
        refine : int

        Returns
        -------
        x : (N, k) array
        """
        x = self.start(x0, d)
        for _ in range(1 + refine):
            x = x + self.step(self.gradient(x, c), x, d)
        return x

    def residuals(self, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``|C x - d|`` per row: the Euclidean norm over the k columns, shape (m,)."""
        if not self.C.shape[0]:
            return np.zeros(0)
        return np.linalg.norm(self.C @ x - d, axis=1)


class NullSpaceSolver(_Quadratic):
    """The null-space method (ECLS eq. 14-21), per constraint component; exact constraints.

    Examples
    --------
    Minimise ``|x|^2`` with ``x0 + x1 = 2`` and a redundant copy of that row:

    >>> C = sp.csr_matrix(np.array([[1.0, 1.0], [2.0, 2.0]]))
    >>> s = NullSpaceSolver(C, H=sp.identity(2))
    >>> x = s.solve(np.zeros((2, 1)), np.array([[2.0], [4.0]]), np.zeros((2, 1)))
    >>> np.round(x.ravel(), 12).tolist(), s.kept.tolist()
    ([1.0, 1.0], [True, False])
    """

    method = "null_space"

    def __init__(self, C: sp.spmatrix, *, A: sp.spmatrix | None = None, H: sp.spmatrix | None = None,
                 what: str = "system", rank_tol: float = RANK_TOL, analysis: RankAnalysis | None = None,
                 beta: float = 0.0, per_update: bool = False) -> None:
        super().__init__(C, A, H, analysis, rank_tol)
        Z = self.ra.Z
        self._Zt = sp.csr_matrix(Z.T)
        self._touched = np.flatnonzero(self.ra.touched)  # start() projects these rows on every solve
        self._ZcT = sp.csr_matrix(self.ra.Zc.T)
        self._Xp_t = sp.csr_matrix(self.ra.Xp[self._touched])
        self._Zc_t = sp.csr_matrix(self.ra.Zc[self._touched])
        if self.A is not None:
            AZ = (self.A @ Z).tocsc()
            Hr = (AZ.T @ AZ).tocsc()
        else:
            assert self.H is not None
            Hr = (self._Zt @ self.H @ Z).tocsc()
        self._f = fz.cholesky(Hr, f"{what} (null space)", sweeps=per_update) if Z.shape[1] else None
        self.factorizations = int(self._f is not None)

    @property
    def nbytes(self) -> int:
        """Bytes held by the factor and the basis matrices."""
        total = int(self._f.nbytes) if self._f is not None else 0
        return total + _nbytes(self.ra.Z) + _nbytes(self.ra.Xp) + self._matrix_bytes()

    def start(self, x0: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``x0`` projected onto the kept constraints."""
        x = x0.copy()
        dk = np.where(self.kept[:, None], d, 0.0)
        x[self._touched] = self._Xp_t @ dk + self._Zc_t @ (self._ZcT @ x0)
        return x

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``Z (Z^T H Z)^{-1} Z^T r``: a correction that keeps every kept row."""
        if self._f is None:
            return np.zeros_like(x)
        return self.ra.Z @ self._f.solve(self._Zt @ r)


class KKTSolver(_Quadratic):
    """Lagrange multipliers on a scaled saddle-point system; exact to round-off."""

    method = "kkt"

    def __init__(self, C: sp.spmatrix, *, A: sp.spmatrix | None = None, H: sp.spmatrix | None = None,
                 what: str = "system", rank_tol: float = RANK_TOL, analysis: RankAnalysis | None = None,
                 beta: float = 0.0, per_update: bool = False) -> None:
        super().__init__(C, A, H, analysis, rank_tol)
        Hf = self._full_H()
        dg = Hf.diagonal()
        self._kscale = float(np.sqrt(np.mean(np.abs(dg[dg != 0])))) if np.any(dg != 0) else 1.0
        Cs = self.Ck * self._kscale
        K = sp.bmat([[Hf, Cs.T], [Cs, None]], format="csc")
        self._f = fz.ldl(K, f"{what} (KKT)")
        self.factorizations = 1

    @property
    def nbytes(self) -> int:
        """Bytes held by the factor and the matrices."""
        return int(self._f.nbytes) + self._matrix_bytes()

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The primal part of the KKT solve for residuals ``r`` and ``d - C x``."""
        rc = d[self.kept] - self.Ck @ x
        rhs = np.vstack([r, rc * self._kscale])
        return self._f.solve(rhs)[: self.N]


class PenaltySolver(_Quadratic):
    """``beta**2 C^T C`` added to the objective (eq. 4.2); constraints hold approximately."""

    method = "penalty"

    def __init__(self, C: sp.spmatrix, *, A: sp.spmatrix | None = None, H: sp.spmatrix | None = None,
                 what: str = "system", rank_tol: float = RANK_TOL, analysis: RankAnalysis | None = None,
                 beta: float = 1.0e4, per_update: bool = False) -> None:
        super().__init__(C, A, H, analysis, rank_tol)
        self.beta = beta
        self._Ckt = sp.csr_matrix(self.Ck.T)
        self._f = fz.cholesky((self._full_H() + beta ** 2 * (self._Ckt @ self.Ck)).tocsc(), f"{what} (penalty)",
                              sweeps=per_update)
        self.factorizations = 1

    @property
    def nbytes(self) -> int:
        """Bytes held by the factor and the matrices."""
        return int(self._f.nbytes) + self._matrix_bytes()

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The penalised normal equations' correction."""
        rc = d[self.kept] - self.Ck @ x
        return self._f.solve(r + self.beta ** 2 * (self._Ckt @ rc))


#: The methods by SPEC name.
METHODS: dict[str, Any] = {"null_space": NullSpaceSolver, "kkt": KKTSolver, "penalty": PenaltySolver}


def constrained_solver(C: sp.spmatrix, *, A: sp.spmatrix | None = None, H: sp.spmatrix | None = None,
                       method: str = "null_space", beta: float = 1.0e4, what: str = "system",
                       rank_tol: float = RANK_TOL, analysis: RankAnalysis | None = None,
                       per_update: bool = False) -> ConstrainedSolver:
    """Factor once for ``min 1/2 x^T H x - g^T x s.t. C x = d`` by ``method``.

    Parameters
    ----------
    C : (m, N) sparse matrix
        Hard constraint rows, in priority order.
    A : (l, N) sparse matrix, optional
        Least-squares operator, ``H = A^T A``. Give ``A`` or ``H``.
    H : (N, N) sparse matrix, optional
        Symmetric positive semi-definite quadratic form.
    method : {"null_space", "kkt", "penalty"}
    beta : float
        Penalty weight (``method="penalty"``).
    what : str
        Name used in error messages.
    rank_tol : float
        Relative tolerance of the dependency test.
    analysis : RankAnalysis, optional
        :func:`~solver.linalg.rank.rank_analysis` of ``C``, when the caller already has it.
    per_update : bool
        The system is back-substituted on every update with a few columns: a
        Cholesky factor gets the supernodal sweeps (:func:`~solver.linalg.factorization.cholesky`).

    Returns
    -------
    ConstrainedSolver

    Raises
    ------
    ValueError
        An unknown method, or not exactly one of ``A`` and ``H``.
    FactorizationError
        The reduced (or KKT, or penalised) system is singular: the soft rows
        and the kept constraints leave some motion undetermined.

    Examples
    --------
    >>> C = sp.csr_matrix(np.array([[1.0, -1.0]]))
    >>> s = constrained_solver(C, H=sp.identity(2), method="kkt")
    >>> np.round(s.solve(np.zeros((2, 1)), np.array([[2.0]]), None).ravel(), 12).tolist()
    [1.0, -1.0]
    """
    cls = METHODS.get(method)
    if cls is None:
        raise ValueError(f"method must be one of {list(METHODS)}, got {method!r}")
    solver: ConstrainedSolver = cls(C, A=A, H=H, what=what, rank_tol=rank_tol, analysis=analysis, beta=beta,
                                    per_update=per_update)
    return solver
