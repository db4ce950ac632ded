"""Priority-ordered rank analysis of hard constraint rows (ECLS §3.2 and §5).

Constraint rows are ranked in priority order (their order in ``C``). Within
each connected component of the constraint graph, an unpivoted Householder QR
of ``C^T`` measures each row's distance from the span of the rows before it;
a row at relative distance ``<= rank_tol`` is *dependent* and dropped (the
paper's "skip the column"), and the rows after it are measured again against
the kept rows only (:func:`_independent_columns`). The result also carries
the per-component null-space basis that :class:`~solver.linalg.constrained.NullSpaceSolver`
uses. After a solve, :meth:`RankAnalysis.dropped_residuals` evaluates the
dropped rows: consistent ones are redundant, inconsistent ones conflicting.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..ops.unique import unique

__all__ = ["RankAnalysis", "rank_analysis", "constraint_components", "RANK_TOL"]

#: Relative distance of a constraint row from the span of earlier rows below
#: which it counts as dependent.
RANK_TOL = 1e-9


@dataclass(frozen=True, eq=False)
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
        return np.linalg.norm(C[drop] @ xp - d[drop], axis=1)


def constraint_components(C: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, int]:
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
    ulab, rlab, ncomp = constraint_components(C)
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
        comps = unique(ulab[uo])
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
    def cat(parts: list, dt: type) -> np.ndarray:
        return np.concatenate(parts).astype(dt) if parts else np.zeros(0, dt)

    Xp = sp.csr_matrix((cat(xp_v, float), (cat(xp_r, np.int64), cat(xp_c, np.int64))), shape=(N, m))
    Zc = sp.csr_matrix((cat(z_v, float), (cat(z_r, np.int64), cat(z_c, np.int64))), shape=(N, ncol))
    free = np.flatnonzero(~touched)
    Zf = sp.csr_matrix((np.ones(free.size), (free, np.arange(free.size))), shape=(N, free.size))
    Z = sp.hstack([Zf, Zc], format="csr")
    Zc_full = sp.hstack([sp.csr_matrix((N, free.size)), Zc], format="csr")
    return RankAnalysis(kept=kept, Xp=Xp, Z=Z, Zc=Zc_full, touched=touched,
                        components=int(comps.size) if m else 0, largest=largest)
