"""Equality-constrained quadratic minimisation with three exact methods.

Solves ::

    min_x  1/2 x^T H x - g^T x     subject to   C x = d            (ECLS eq. 13)

for ``x`` of shape (N, k) (k right-hand sides sharing ``H`` and ``C``), where
``H = A^T A`` (least squares, ``g = A^T c``) or a given symmetric positive
semi-definite ``H`` (the harmonic rotation system). ``H`` need only be
definite on the null space of ``C``.

Methods (``method``):

``null_space``
    ECLS §3.2, eq. (14)-(21): ``C^T = Q R``, ``x = Q1 R1^{-T} d + Q2 z``, and
    ``z`` from the reduced normal equations ``(Q2^T H Q2) z = Q2^T (g - H x_p)``.
    The QR factorizations are done **per connected component** of the
    constraint graph (unknowns linked by a shared constraint row), so ``Q2`` is
    block diagonal: a positional constraint is a 1x1 block, a sliding node a
    3x3 block, a rigid feature one block per coordinate. The reduced matrix
    keeps the sparsity of ``H`` except inside a component, which is what made
    the papers' global version dense with many multi-vertex constraints.
``kkt``
    Lagrange multipliers: ``[[H, C^T], [C, 0]] [x; lambda] = [g; d]`` with a
    sparse symmetric indefinite factorization (:func:`factorization.ldl`).
    ``C`` and ``d`` are scaled so both blocks have comparable magnitude.
``penalty``
    ``(H + beta^2 C^T C) x = g + beta^2 C^T d`` (Masuda & Ogawa eq. 4.2); the
    constraints hold only approximately, and the residual is reported.

Redundancy and conflicts (ECLS §5): constraint rows are ranked in priority
order (their order in ``C``). Within each component, an unpivoted Householder
QR of ``C^T`` measures each row's distance from the span of the rows before
it; a row at relative distance ``<= rank_tol`` is *dependent* and dropped (the
paper's "skip the column"), and the rows after it are measured again against
the kept rows only (:func:`_independent_columns`). Every method uses only the kept rows. After a
solve, :meth:`ConstrainedSolver.dropped_residuals` evaluates the dropped rows:
consistent ones are redundant, inconsistent ones conflicting.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from . import factorization as fz

__all__ = ["ConstrainedSolver", "RankAnalysis", "rank_analysis", "METHODS"]

METHODS = ("null_space", "kkt", "penalty")
#: Relative distance of a constraint row from the span of earlier rows below
#: which it counts as dependent.
RANK_TOL = 1e-9


@dataclass
class RankAnalysis:
    """Per-component QR of ``C^T`` (ECLS §3.2 and §5).

    Attributes
    ----------
    kept : (m,) bool array
        Rows that are independent of the rows before them.
    Xp : (N, m) sparse matrix
        ``x_p = Xp @ d`` is the minimum-norm solution of the kept rows on the
        constrained unknowns (``Q1 R1^{-T}`` per component; zero columns for
        dropped rows).
    Z : (N, N - rank) sparse matrix
        Orthonormal basis of the null space of the kept rows (``Q2`` per
        component, identity on unknowns that no row touches).
    Zc : (N, q) sparse matrix
        The component part of ``Z`` (its columns on constrained unknowns).
    touched : (N,) bool array
        Unknowns that appear in some constraint row.
    components : int
        Number of connected components of the constraint graph.
    largest : tuple of int
        (unknowns, rows) of the largest component.
    """

    kept: np.ndarray
    Xp: sp.csr_matrix
    Z: sp.csr_matrix
    Zc: sp.csr_matrix
    touched: np.ndarray
    components: int
    largest: tuple[int, int]

    def dropped_residuals(self, C: sp.csr_matrix, d: np.ndarray) -> np.ndarray:
        """|C_q x - d_q| of each dropped row ``q`` for any ``x`` meeting the kept rows.

        A dropped row is a combination of kept rows, so its value is the same
        at every feasible ``x``; the minimum-norm ``x_p = Xp d`` serves. Zero
        (to round-off) means redundant, non-zero conflicting (ECLS §5).
        """
        drop = np.flatnonzero(~self.kept)
        if not drop.size:
            return np.zeros(0)
        xp = self.Xp @ np.where(self.kept[:, None], d, 0.0)
        return np.abs(C[drop] @ xp - d[drop]).max(axis=1)


def _component_labels(C: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, int]:
    """Component label of each touched unknown and of each row (bipartite graph)."""
    m, N = C.shape
    Cc = sp.csr_matrix((np.ones(C.nnz), C.indices, C.indptr), shape=C.shape)
    G = sp.bmat([[None, Cc.T], [Cc, None]], format="csr")
    _, lab = connected_components(G, directed=False)
    return lab[:N], lab[N:], int(lab.max()) + 1 if lab.size else 0


def _independent_columns(Ct: np.ndarray, norms: np.ndarray, tol: float) -> np.ndarray:
    """Which columns of ``Ct`` (u, r) are independent of the columns before them.

    Blocked Gram-Schmidt with the paper's skip (ECLS §5): the columns not yet
    decided are projected (twice) off the orthonormal basis of the kept ones
    and factored by an unpivoted QR; every column before the first small
    diagonal entry is kept, that column is dropped, and the pass restarts
    after it. One QR per dependent column.
    """
    u, r = Ct.shape
    keep = np.zeros(r, bool)
    Q = np.zeros((u, 0))
    j = 0
    while j < r and Q.shape[1] < u:
        B = Ct[:, j:]
        B = B - Q @ (Q.T @ B)
        B = B - Q @ (Q.T @ B)
        q, R = np.linalg.qr(B)
        d = np.abs(np.diagonal(R))
        ok = d > tol * norms[j:j + d.size]
        bad = int(np.argmin(ok)) if not ok.all() else d.size
        keep[j:j + bad] = True
        Q = np.hstack([Q, q[:, :bad]])
        j += bad + (1 if bad < d.size else 0)
    return keep


def rank_analysis(C: sp.csr_matrix, rank_tol: float = RANK_TOL) -> RankAnalysis:
    """Rank-revealing, priority-ordered per-component QR of ``C^T``.

    Parameters
    ----------
    C : (m, N) sparse matrix
        Constraint rows in priority order (earlier rows win).
    rank_tol : float
        Relative tolerance of the dependency test.

    Returns
    -------
    RankAnalysis

    Examples
    --------
    >>> C = sp.csr_matrix(np.array([[1.0, 0, 0], [1.0, 0, 0], [1.0, -1.0, 0]]))
    >>> ra = rank_analysis(C)
    >>> ra.kept.tolist(), ra.Z.shape
    ([True, False, True], (3, 1))
    """
    C = sp.csr_matrix(C, dtype=np.float64)
    C.sum_duplicates()
    C.eliminate_zeros()
    m, N = C.shape
    nnz_rows = np.diff(C.indptr) > 0
    touched = np.zeros(N, bool)
    touched[C.indices] = True
    kept = np.zeros(m, bool)
    ulab, rlab, ncomp = _component_labels(C)
    ulab = np.where(touched, ulab, -1)
    rlab = np.where(nnz_rows, rlab, -1)
    xp_r, xp_c, xp_v = [], [], []
    z_r, z_c, z_v = [], [], []
    ncol = 0
    largest = (0, 0)
    if m:
        # order unknowns and rows by component, keeping their own order inside
        uo = np.flatnonzero(touched)
        uo = uo[np.argsort(ulab[uo], kind="stable")]
        ro = np.flatnonzero(nnz_rows)
        ro = ro[np.argsort(rlab[ro], kind="stable")]
        comps = np.unique(ulab[uo])
        ustart = np.searchsorted(ulab[uo], comps)
        uend = np.searchsorted(ulab[uo], comps, side="right")
        rstart = np.searchsorted(rlab[ro], comps)
        rend = np.searchsorted(rlab[ro], comps, side="right")
        usize = uend - ustart
        rsize = rend - rstart
        if comps.size:
            b = int(np.argmax(usize))
            largest = (int(usize[b]), int(rsize[b]))
        # local indices
        uloc = np.empty(N, np.int64)
        uloc[uo] = np.arange(uo.size) - np.repeat(ustart, usize)
        rloc = np.empty(m, np.int64)
        rloc[ro] = np.arange(ro.size) - np.repeat(rstart, rsize)
        comp_of_label = np.full(ncomp, -1, np.int64)
        comp_of_label[comps] = np.arange(comps.size)
        Ccoo = C.tocoo()
        e_comp = comp_of_label[rlab[Ccoo.row]]
        shapes = np.stack([usize, rsize], axis=1)
        keys, group = np.unique(shapes, axis=0, return_inverse=True)
        group = group.ravel()
        for g, (u, r) in enumerate(keys):
            members = np.flatnonzero(group == g)  # component indices in this group
            pos = np.full(comps.size, -1, np.int64)
            pos[members] = np.arange(members.size)
            sel = pos[e_comp] >= 0
            Ct = np.zeros((members.size, u, r))  # C^T blocks
            Ct[pos[e_comp[sel]], uloc[Ccoo.col[sel]], rloc[Ccoo.row[sel]]] = Ccoo.data[sel]
            Q, R = np.linalg.qr(Ct, mode="complete")
            norms = np.linalg.norm(Ct, axis=1)  # (G, r)
            diag = np.abs(np.diagonal(R, axis1=1, axis2=2)) if min(u, r) else np.zeros((members.size, 0))
            clean = (r <= u) & np.all(diag > rank_tol * norms[:, :min(u, r)], axis=1) if r <= u \
                else np.zeros(members.size, bool)
            urows = uo[np.add.outer(ustart[members], np.arange(u))]  # (G, u) global unknowns
            rrows = ro[np.add.outer(rstart[members], np.arange(r))]  # (G, r) global rows
            # components without dependent rows: use this QR
            ci = np.flatnonzero(clean)
            if ci.size:
                Q1 = Q[ci, :, :r]
                R1 = R[ci, :r, :r]
                # Xp = Q1 R1^{-T}: solve R1 Y^T = Q1^T
                Y = np.linalg.solve(R1, np.transpose(Q1, (0, 2, 1)))  # (G, r, u) = (Q1 R1^{-T})^T
                xp_r.append(np.repeat(urows[ci], r, axis=1).ravel())
                xp_c.append(np.tile(rrows[ci], (1, u)).ravel())
                xp_v.append(np.transpose(Y, (0, 2, 1)).reshape(ci.size, -1).ravel())
                kept[rrows[ci].ravel()] = True
                q = u - r
                if q:
                    Q2 = Q[ci, :, r:]  # (G, u, q)
                    cols = ncol + np.arange(ci.size * q).reshape(ci.size, q)
                    z_r.append(np.repeat(urows[ci], q, axis=1).ravel())
                    z_c.append(np.tile(cols, (1, u)).ravel())
                    z_v.append(Q2.reshape(ci.size, -1).ravel())
                    ncol += ci.size * q
            for j in np.flatnonzero(~clean):
                keep_local = np.flatnonzero(_independent_columns(Ct[j], norms[j], rank_tol))
                kept[rrows[j, keep_local]] = True
                rk = keep_local.size
                if rk:
                    Qk, Rk = np.linalg.qr(Ct[j][:, keep_local], mode="complete")
                    Y = np.linalg.solve(Rk[:rk, :rk], Qk[:, :rk].T)  # (rk, u)
                    xp_r.append(np.repeat(urows[j], rk))
                    xp_c.append(np.tile(rrows[j, keep_local], u))
                    xp_v.append(Y.T.ravel())
                    Q2 = Qk[:, rk:]
                else:
                    Q2 = np.eye(u)
                q = Q2.shape[1]
                if q:
                    z_r.append(np.repeat(urows[j], q))
                    z_c.append(np.tile(ncol + np.arange(q), u))
                    z_v.append(Q2.ravel())
                    ncol += q
    cat = (lambda parts, dt: np.concatenate(parts).astype(dt) if parts else np.zeros(0, dt))
    Xp = sp.csr_matrix((cat(xp_v, float), (cat(xp_r, np.int64), cat(xp_c, np.int64))), shape=(N, m))
    Zc = sp.csr_matrix((cat(z_v, float), (cat(z_r, np.int64), cat(z_c, np.int64))), shape=(N, ncol))
    free = np.flatnonzero(~touched)
    Zf = sp.csr_matrix((np.ones(free.size), (free, np.arange(free.size))), shape=(N, free.size))
    Z = sp.hstack([Zf, Zc], format="csr")
    Zc_full = sp.hstack([sp.csr_matrix((N, free.size)), Zc], format="csr")
    return RankAnalysis(kept=kept, Xp=Xp, Z=Z, Zc=Zc_full, touched=touched,
                        components=int(comps.size) if m else 0, largest=largest)


class ConstrainedSolver:
    """Factor once, then solve ``min 1/2 x^T H x - g^T x s.t. C x = d`` per right-hand side.

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
        :func:`rank_analysis` of ``C``, when the caller already has it.

    Raises
    ------
    FactorizationError
        The reduced (or KKT, or penalised) system is singular: the soft rows
        and the kept constraints leave some motion undetermined.

    Examples
    --------
    Minimise ``|x|^2`` with ``x0 + x1 = 2`` and a redundant copy of that row:

    >>> C = sp.csr_matrix(np.array([[1.0, 1.0], [2.0, 2.0]]))
    >>> s = ConstrainedSolver(C, H=sp.identity(2), method="null_space")
    >>> x = s.solve(np.zeros((2, 1)), np.array([[2.0], [4.0]]), np.zeros((2, 1)))
    >>> np.round(x.ravel(), 12).tolist(), s.kept.tolist()
    ([1.0, 1.0], [True, False])
    """

    def __init__(self, C: sp.spmatrix, *, A: sp.spmatrix | None = None, H: sp.spmatrix | None = None,
                 method: str = "null_space", beta: float = 1.0e4, what: str = "system",
                 rank_tol: float = RANK_TOL, analysis: RankAnalysis | None = None) -> None:
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        if (A is None) == (H is None):
            raise ValueError("give exactly one of A and H")
        self.method = method
        self.C = sp.csr_matrix(C, dtype=np.float64)
        self.A = None if A is None else sp.csr_matrix(A)
        self.At = None if A is None else sp.csr_matrix(self.A.T)
        self.H = None if H is None else sp.csr_matrix(H)
        self.N = self.C.shape[1]
        self.ra = analysis if analysis is not None else rank_analysis(self.C, rank_tol)
        self.kept = self.ra.kept
        self.Ck = self.C[np.flatnonzero(self.kept)]
        self.beta = beta
        if method == "null_space":
            Z = self.ra.Z
            self._Zt = sp.csr_matrix(Z.T)
            if self.A is not None:
                AZ = (self.A @ Z).tocsc()
                Hr = (AZ.T @ AZ).tocsc()
            else:
                Hr = (self._Zt @ self.H @ Z).tocsc()
            self._f = fz.cholesky(Hr, f"{what} (null space)") if Z.shape[1] else None
        elif method == "kkt":
            Hf = self._full_H()
            d = Hf.diagonal()
            scale = float(np.sqrt(np.mean(np.abs(d[d != 0])))) if np.any(d != 0) else 1.0
            self._kscale = scale
            Cs = self.Ck * scale
            K = sp.bmat([[Hf, Cs.T], [Cs, None]], format="csc")
            self._f = fz.ldl(K, f"{what} (KKT)")
        else:
            Hf = self._full_H()
            self._Ckt = sp.csr_matrix(self.Ck.T)
            self._f = fz.cholesky((Hf + beta ** 2 * (self._Ckt @ self.Ck)).tocsc(), f"{what} (penalty)")

    def _full_H(self) -> sp.csr_matrix:
        if self.H is not None:
            return self.H
        return sp.csr_matrix(self.At @ self.A)

    @property
    def nbytes(self) -> int:
        """Bytes held by the factor and the basis matrices."""
        total = int(self._f.nbytes) if self._f is not None else 0
        for M in (self.ra.Z, self.ra.Xp, self.C):
            total += int(M.data.nbytes + M.indices.nbytes + M.indptr.nbytes)
        return total

    def gradient(self, x: np.ndarray, c: np.ndarray | None) -> np.ndarray:
        """``g - H x``: with ``A``, ``A^T (c - A x)``; with ``H``, ``-H x`` (``c`` ignored)."""
        if self.A is not None:
            return self.At @ (c - self.A @ x)
        return -(self.H @ x)

    def start(self, x0: np.ndarray, d: np.ndarray) -> np.ndarray:
        """A starting point: ``x0`` projected onto the kept constraints (null space), else ``x0``."""
        if self.method != "null_space":
            return x0.copy()
        ra = self.ra
        x = x0.copy()
        t = ra.touched
        dk = np.where(self.kept[:, None], d, 0.0)
        proj = ra.Xp @ dk + ra.Zc @ (ra.Zc.T @ x0)
        x[t] = proj[t]
        return x

    def step(self, r: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Correction ``dx`` for gradient residual ``r = g - H x`` at ``x``."""
        if self.method == "null_space":
            if self._f is None:
                return np.zeros_like(x)
            return self.ra.Z @ self._f.solve(self._Zt @ r)
        rc = d[self.kept] - self.Ck @ x
        if self.method == "kkt":
            rhs = np.vstack([r, rc * self._kscale])
            return self._f.solve(rhs)[: self.N]
        return self._f.solve(r + self.beta ** 2 * (self._Ckt @ rc))

    def solve(self, x0: np.ndarray, d: np.ndarray, c: np.ndarray | None, refine: int = 1) -> np.ndarray:
        """Solve from ``x0`` (the rest state: residual form) with ``refine`` refinement steps.

        Parameters
        ----------
        x0 : (N, k) array
        d : (m, k) array
            Targets of every row (dropped rows are ignored).
        c : (l, k) array or None
            Least-squares right-hand side when built from ``A``.
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
        """|C x - d| per row (max over the k columns), shape (m,)."""
        if not self.C.shape[0]:
            return np.zeros(0)
        return np.abs(self.C @ x - d).max(axis=1)
