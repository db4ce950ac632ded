"""Supernodal back-substitution over an exported LU or Cholesky factor, for systems up to medium size.

A factor is cut into supernodes: runs of consecutive columns ``c0..c1-1`` of
``L`` that share one row pattern ``R`` below their diagonal block (and, the
pattern being symmetric, rows of ``U`` that share the column pattern ``R``).
Each supernode keeps four dense blocks, row-major: the strictly lower part of
``L[c0:c1, c0:c1]``, the strictly upper part of ``U[c0:c1, c0:c1]``,
``L[R, c0:c1]^T`` and ``U[c0:c1, R]``, and one index array ``R``. A
back-substitution then reads every value once per sweep as a contiguous
stream (no index per entry) and touches the right-hand side through ``R``
once per supernode: forward, ``y[R] -= L[R, c] y[c]`` as three axpys into a
dense buffer scattered once; backward, ``y[c] -= U[c, R] y[R]`` as dot
products over a buffer gathered once.

Why not PARDISO's or CHOLMOD's own solve: their solve phases cost more per
call than these sweeps at every size measured (``benchmarks/bench_update.py``,
``benchmarks/measure_choices.py --only supernodal``). The two-thread split is
the elimination tree's: the two subtrees under the top separator are swept at
once and their updates of the top summed after.

An LU factor comes from :func:`~solver.linalg.multifrontal.lu_multifrontal`
(tetmorph's multifrontal LU without pivoting, written straight into these
blocks), or from SuperLU without pivoting on PARDISO's METIS ordering
(:func:`lu_supernodal`, kept as an independent second factorization for the
tests); the mean-value systems are diagonally dominant (every row is ``1`` on
the diagonal and minus convex weights elsewhere). A Cholesky factor is
CHOLMOD's ``L`` (:func:`cholmod_supernodal`; ``U = L^T`` shares its
off-diagonal blocks). A factor that needed a row exchange, that holds an entry
of ``U`` outside the pattern of ``L^T`` or lacks a diagonal entry, or whose
probe solve misses a backward error of :data:`PROBE_TOL` is refused with
:class:`Unsuitable`, and the caller keeps PARDISO (which pivots) or CHOLMOD.

Many right-hand sides (a DOE block) are swept together, each factor entry
read once for all of them (:data:`GROUPED_COLUMNS`).

Every solve allocates its own work arrays: one factor serves concurrent
solves without a lock.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

__all__ = ["SupernodalFactor", "Unsuitable", "supernode_starts", "tree_split", "lu_supernodal", "cholmod_supernodal"]

#: Up to this many right-hand sides a solve sweeps three at a time (the fixed-width kernel keeps
#: them in registers); beyond, one sweep takes all of them, so each factor entry is read once.
#: ``benchmarks/measure_choices.py --only supernodal`` measures both against CHOLMOD's solve.
GROUPED_COLUMNS = 9
#: Normwise backward error a probe solve (in double precision) must meet at set-up.
PROBE_TOL = 1e-12


class Unsuitable(Exception):
    """The factor cannot be laid out in supernodes here (the caller uses its own backend)."""


def supernode_starts(indptr: np.ndarray, first: np.ndarray, breaks: tuple[int, ...] = ()) -> np.ndarray:
    """First column of every fundamental supernode of a lower factor, and ``n`` at the end.

    Column ``j + 1`` continues column ``j``'s supernode when it is ``j``'s parent
    in the elimination tree (the first row below ``j``'s diagonal) and holds
    one entry less: then their patterns below the diagonal block agree.

    Parameters
    ----------
    indptr : (n + 1,) int array
        CSC column pointers of ``L`` (diagonal included).
    first : (n,) int array
        First row below each column's diagonal (-1 for none), :func:`_column_stats`.
    breaks : tuple of int
        Columns that must start a supernode (a supernode may always be cut: each
        piece's pattern is that of its last column).

    Returns
    -------
    (s + 1,) int64 array
    """
    n = indptr.size - 1
    cnt = np.diff(indptr)
    join = np.zeros(n, bool)
    j = np.arange(n - 1)
    join[1:] = (first[:-1] == j + 1) & (cnt[:-1] == cnt[1:] + 1)
    join[[b for b in breaks if b < n]] = False
    return np.r_[np.flatnonzero(~join), n].astype(np.int64)


@numba.njit(cache=True, nogil=True)
def _subtrees(parent):  # pragma: no cover - compiled
    """Size and smallest column of every column's subtree (parents come after their children)."""
    n = parent.shape[0]
    size = np.ones(n, np.int64)
    lo = np.arange(n)
    for c in range(n):
        p = parent[c]
        if p >= 0:
            size[p] += size[c]
            lo[p] = min(lo[p], lo[c])
    return size, lo


def tree_split(first: np.ndarray, work: np.ndarray) -> tuple[int, int]:
    """Columns ``(m1, m2)`` cutting a factor for a two-thread sweep.

    ``[0, m1)`` and ``[m1, m2)`` are unions of whole subtrees of the elimination
    tree, balanced by ``work``; ``[m2, n)`` is the chain above them (for a
    nested-dissection order, the top separator). For a complete symbolic pattern
    their columns never update each other, only the chain's (the caller checks
    the stored pattern, which may lack dropped zeros). ``(0, 0)`` when the order does not lay subtrees out
    as contiguous ranges (one thread then sweeps everything).

    Parameters
    ----------
    first : (n,) int array
        Parent of every column in the elimination tree (-1 for a root).
    work : (n,) array
        Cost of every column (its entries).
    """
    n = first.size
    if n < 2:
        return 0, 0
    parent = np.asarray(first, np.int64)
    order = np.argsort(parent, kind="stable")
    sorted_parent = parent[order]
    roots = order[sorted_parent < 0]

    def children(v: int) -> np.ndarray:
        a, b = np.searchsorted(sorted_parent, [v, v + 1])
        return order[a:b]

    kids, top = roots, n
    while kids.size == 1:  # down the chain of single children
        top = int(kids[0])
        kids = children(top)
    if kids.size < 2:
        return 0, 0
    if top < n:  # the chain must be the columns top..n-1
        chain = [top]
        while parent[chain[-1]] >= 0:
            chain.append(int(parent[chain[-1]]))
        if sorted(chain) != list(range(top, n)):
            return 0, 0
    size, lo = _subtrees(parent)
    kids = np.sort(kids)
    if lo[kids[0]] != 0 or kids[-1] != top - 1 or np.any(lo[kids] != kids - size[kids] + 1) \
            or np.any(lo[kids[1:]] != kids[:-1] + 1):
        return 0, 0
    cum = np.cumsum(work[:top])
    ends = kids[:-1] + 1  # candidate cuts between the subtrees
    m1 = int(ends[np.argmin(np.abs(cum[ends - 1] - cum[-1] / 2))])
    return m1, top


@numba.njit(cache=True, nogil=True)
def _column_stats(Lp, Li):  # pragma: no cover - compiled
    """First row below the diagonal of every column (-1 when none) and how many rows lie below it."""
    n = Lp.shape[0] - 1
    first = np.full(n, -1, np.int64)
    below = np.zeros(n, np.int64)
    for c in range(n):
        m = n
        for p in range(Lp[c], Lp[c + 1]):
            r = Li[p]
            if r > c:
                below[c] += 1
                if r < m:
                    m = r
        if m < n:
            first[c] = m
    return first, below


@numba.njit(cache=True, nogil=True)
def _rows_below(starts, Lp, Li, rstart, R):  # pragma: no cover - compiled
    """``R``: for every supernode, the rows below the diagonal of its last column."""
    for s in range(starts.shape[0] - 1):
        c = starts[s + 1] - 1
        k = rstart[s]
        for p in range(Lp[c], Lp[c + 1]):
            if Li[p] > c:
                R[k] = Li[p]
                k += 1


@numba.njit(cache=True, nogil=True)
def _transpose(Up, Ui, Ux):  # pragma: no cover - compiled
    """CSC of ``U^T`` (the rows of ``U``) from the CSC of ``U``, by a counting sort."""
    n = Up.shape[0] - 1
    nnz = Up[n]
    Tp = np.zeros(n + 1, np.int64)
    for p in range(nnz):
        Tp[Ui[p] + 1] += 1
    for i in range(n):
        Tp[i + 1] += Tp[i]
    nxt = Tp[:-1].copy()
    Ti = np.empty(nnz, np.int64)
    Tx = np.empty(nnz, np.float64)
    for c in range(n):
        for p in range(Up[c], Up[c + 1]):
            r = Ui[p]
            q = nxt[r]
            Ti[q] = c
            Tx[q] = Ux[p]
            nxt[r] = q + 1
    return Tp, Ti, Tx


@numba.njit(cache=True, nogil=True)
def _fill(starts, Lp, Li, Lx, lower, rstart, R, bstart, dstart, B, D, dinv):  # pragma: no cover - compiled
    """Scatter one triangle's columns (``lower``: ``L`` by columns; else ``U^T`` by columns) into the blocks.

    Returns False when an entry falls outside its supernode's pattern.
    """
    n = Lp.shape[0] - 1
    where = np.full(n, -1, np.int64)
    for s in range(starts.shape[0] - 1):
        c0, c1 = starts[s], starts[s + 1]
        w = c1 - c0
        r0, r = rstart[s], rstart[s + 1] - rstart[s]
        for i in range(r):
            where[R[r0 + i]] = i
        for c in range(c0, c1):
            a = c - c0
            for p in range(Lp[c], Lp[c + 1]):
                row = Li[p]
                v = Lx[p]
                if row == c:
                    if v == 0.0:
                        return False
                    dinv[c] = 1.0 / v
                elif row < c:
                    return False
                elif row < c1:
                    e = row - c0
                    if lower:
                        D[dstart[s] + e * w + a] = v
                    else:
                        D[dstart[s] + a * w + e] = v
                else:
                    i = where[row]
                    if i < 0:
                        return False
                    B[bstart[s] + a * r + i] = v
        for i in range(r):
            where[R[r0 + i]] = -1
    return True


@numba.njit(cache=True, nogil=True, inline="always", fastmath=True, boundscheck=False)
def _diag_row3(D, base, lo, hi, g, c0, a, y0, y1, y2):  # pragma: no cover - compiled
    """Row ``a`` of a diagonal block: ``y_q[c0 + a] = (y_q[c0 + a] - D[a, lo:hi] y_q[c0 + lo:c0 + hi]) g``.

    ``y0, y1, y2``: the three right-hand sides, each a contiguous vector (one-dimensional
    views vectorize where a two-dimensional index does not). The forward sweep takes
    ``[0, a)`` of the lower block, the backward ``(a, w)`` of the upper one.
    """
    z = y0.dtype.type(0.0)
    a0 = z
    a1 = z
    a2 = z
    d = D[base + lo:base + hi]
    x0 = y0[c0 + lo:c0 + hi]
    x1 = y1[c0 + lo:c0 + hi]
    x2 = y2[c0 + lo:c0 + hi]
    for e in range(hi - lo):
        v = d[e]
        a0 += v * x0[e]
        a1 += v * x1[e]
        a2 += v * x2[e]
    y0[c0 + a] = (y0[c0 + a] - a0) * g
    y1[c0 + a] = (y1[c0 + a] - a1) * g
    y2[c0 + a] = (y2[c0 + a] - a2) * g


@numba.njit(cache=True, nogil=True, inline="always", fastmath=True, boundscheck=False)
def _diag_row(D, base, lo, hi, g, c0, a, y):  # pragma: no cover - compiled
    """:func:`_diag_row3` for ``y`` of shape (n, k)."""
    k = y.shape[1]
    for e in range(lo, hi):
        v = D[base + e]
        for q in range(k):
            y[c0 + a, q] -= v * y[c0 + e, q]
    for q in range(k):
        y[c0 + a, q] *= g


@numba.njit(cache=True, nogil=True, fastmath=True, boundscheck=False)
def _forward(starts, rstart, R, bstart, LB, dstart, LD, ldinv, s_lo, s_hi, y, acc, top):  # pragma: no cover
    """``y <- L^{-1} y`` over supernodes ``s_lo..s_hi-1``; updates of columns ``>= top`` go to ``acc`` instead.

    ``y`` (3, n) and ``acc`` (3, n - top) are read through one-dimensional row views and
    the block columns through slices, so the inner loops vectorize.
    """
    maxr = 0
    for s in range(s_lo, s_hi):
        maxr = max(maxr, rstart[s + 1] - rstart[s])
    z = y.dtype.type(0.0)
    t0 = np.empty(maxr, y.dtype)
    t1 = np.empty(maxr, y.dtype)
    t2 = np.empty(maxr, y.dtype)
    y0, y1, y2 = y[0], y[1], y[2]
    c0_, c1_, c2_ = acc[0], acc[1], acc[2]
    for s in range(s_lo, s_hi):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        for a in range(w):
            _diag_row3(LD, dstart[s] + a * w, 0, a, ldinv[c0 + a], c0, a, y0, y1, y2)
        if r == 0:
            continue
        for i in range(r):
            t0[i] = z
            t1[i] = z
            t2[i] = z
        a = 0
        b = bstart[s]
        while a + 4 <= w:  # four block columns per pass over t: a quarter of its loads and stores
            c = c0 + a
            p0, p1, p2, p3 = y0[c], y0[c + 1], y0[c + 2], y0[c + 3]
            q0, q1, q2, q3 = y1[c], y1[c + 1], y1[c + 2], y1[c + 3]
            u0, u1, u2, u3 = y2[c], y2[c + 1], y2[c + 2], y2[c + 3]
            L0 = LB[b:b + r]
            L1 = LB[b + r:b + 2 * r]
            L2 = LB[b + 2 * r:b + 3 * r]
            L3 = LB[b + 3 * r:b + 4 * r]
            for i in range(r):
                v0 = L0[i]
                v1 = L1[i]
                v2 = L2[i]
                v3 = L3[i]
                t0[i] += p0 * v0 + p1 * v1 + p2 * v2 + p3 * v3
                t1[i] += q0 * v0 + q1 * v1 + q2 * v2 + q3 * v3
                t2[i] += u0 * v0 + u1 * v1 + u2 * v2 + u3 * v3
            a += 4
            b += 4 * r
        while a < w:  # the last one to three columns
            p0 = y0[c0 + a]
            q0 = y1[c0 + a]
            u0 = y2[c0 + a]
            L0 = LB[b:b + r]
            for i in range(r):
                v0 = L0[i]
                t0[i] += p0 * v0
                t1[i] += q0 * v0
                t2[i] += u0 * v0
            a += 1
            b += r
        rows = R[r0:r0 + r]
        for i in range(r):
            k = rows[i]
            if k < top:
                y0[k] -= t0[i]
                y1[k] -= t1[i]
                y2[k] -= t2[i]
            else:
                c0_[k - top] += t0[i]
                c1_[k - top] += t1[i]
                c2_[k - top] += t2[i]


@numba.njit(cache=True, nogil=True, fastmath=True, boundscheck=False)
def _backward(starts, rstart, R, bstart, UB, dstart, UD, udinv, s_lo, s_hi, y):  # pragma: no cover - compiled
    """``y <- U^{-1} y`` over supernodes ``s_hi-1`` down to ``s_lo`` (later columns already solved).

    One-dimensional views as in :func:`_forward`: the values below a supernode are
    gathered once into three vectors, and each block row is a dot product with them.
    """
    maxr = 0
    for s in range(s_lo, s_hi):
        maxr = max(maxr, rstart[s + 1] - rstart[s])
    z = y.dtype.type(0.0)
    g0 = np.empty(maxr, y.dtype)
    g1 = np.empty(maxr, y.dtype)
    g2 = np.empty(maxr, y.dtype)
    y0, y1, y2 = y[0], y[1], y[2]
    for s in range(s_hi - 1, s_lo - 1, -1):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        if r:
            rows = R[r0:r0 + r]
            for i in range(r):
                k = rows[i]
                g0[i] = y0[k]
                g1[i] = y1[k]
                g2[i] = y2[k]
            a = 0
            b = bstart[s]
            while a + 4 <= w:  # four block rows per pass over the gathered values
                U0 = UB[b:b + r]
                U1 = UB[b + r:b + 2 * r]
                U2 = UB[b + 2 * r:b + 3 * r]
                U3 = UB[b + 3 * r:b + 4 * r]
                s00 = s01 = s02 = s10 = s11 = s12 = z
                s20 = s21 = s22 = s30 = s31 = s32 = z
                for i in range(r):
                    e0 = g0[i]
                    e1 = g1[i]
                    e2 = g2[i]
                    u0 = U0[i]
                    u1 = U1[i]
                    u2 = U2[i]
                    u3 = U3[i]
                    s00 += u0 * e0
                    s01 += u0 * e1
                    s02 += u0 * e2
                    s10 += u1 * e0
                    s11 += u1 * e1
                    s12 += u1 * e2
                    s20 += u2 * e0
                    s21 += u2 * e1
                    s22 += u2 * e2
                    s30 += u3 * e0
                    s31 += u3 * e1
                    s32 += u3 * e2
                c = c0 + a
                y0[c] -= s00
                y1[c] -= s01
                y2[c] -= s02
                y0[c + 1] -= s10
                y1[c + 1] -= s11
                y2[c + 1] -= s12
                y0[c + 2] -= s20
                y1[c + 2] -= s21
                y2[c + 2] -= s22
                y0[c + 3] -= s30
                y1[c + 3] -= s31
                y2[c + 3] -= s32
                a += 4
                b += 4 * r
            while a < w:  # the last one to three rows
                U0 = UB[b:b + r]
                a0 = z
                a1 = z
                a2 = z
                for i in range(r):
                    u = U0[i]
                    a0 += u * g0[i]
                    a1 += u * g1[i]
                    a2 += u * g2[i]
                y0[c0 + a] -= a0
                y1[c0 + a] -= a1
                y2[c0 + a] -= a2
                a += 1
                b += r
        for a in range(w - 1, -1, -1):
            _diag_row3(UD, dstart[s] + a * w, a + 1, w, udinv[c0 + a], c0, a, y0, y1, y2)


@numba.njit(cache=True, nogil=True, inline="always")
def _part(split, part):  # pragma: no cover - compiled
    """Supernodes ``[lo, hi)`` of one of the two subtrees that ``split`` cuts."""
    if part == 0:
        return 0, split[0]
    return split[0], split[1]


@numba.njit(parallel=True, cache=True, nogil=True, fastmath=True, boundscheck=False)
def _sweep3(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, split, y):  # pragma: no cover
    """``y <- U^{-1} L^{-1} y`` for three right-hand sides, ``y`` of shape (3, n).

    ``split = (s1, s2)``: supernodes ``0..s1-1`` and ``s1..s2-1`` are two disjoint
    subtrees of the elimination tree, swept on two threads (forward, their
    updates of the shared top columns summed after; backward, after the top);
    supernodes from ``s2`` on are the top, swept on one thread.
    """
    n = y.shape[1]
    ns = starts.shape[0] - 1
    if split[0] == 0:  # no cut: one thread, no buffers for the top
        _forward(starts, rstart, R, bstart, LB, dstart, LD, ldinv, 0, ns, y, np.zeros((3, 0), y.dtype), n)
        _backward(starts, rstart, R, bstart, UB, dstart, UD, udinv, 0, ns, y)
        return
    top = starts[split[1]]
    acc = np.zeros((2, 3, n - top), y.dtype)
    for part in numba.prange(2):
        s_lo, s_hi = _part(split, part)
        _forward(starts, rstart, R, bstart, LB, dstart, LD, ldinv, s_lo, s_hi, y, acc[part], top)
    for q in range(3):
        for k in range(n - top):
            y[q, top + k] -= acc[0, q, k] + acc[1, q, k]
    _forward(starts, rstart, R, bstart, LB, dstart, LD, ldinv, split[1], ns, y, acc[0], n)
    _backward(starts, rstart, R, bstart, UB, dstart, UD, udinv, split[1], ns, y)
    for part in numba.prange(2):
        s_lo, s_hi = _part(split, part)
        _backward(starts, rstart, R, bstart, UB, dstart, UD, udinv, s_lo, s_hi, y)


@numba.njit(cache=True, nogil=True, fastmath=True, boundscheck=False)
def _forward_wide(starts, rstart, R, bstart, LB, dstart, LD, ldinv, s_lo, s_hi, y, acc, top):  # pragma: no cover
    """:func:`_forward` for ``y`` of shape (n, k): every inner loop runs over the k contiguous columns."""
    k = y.shape[1]
    for s in range(s_lo, s_hi):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        for a in range(w):
            _diag_row(LD, dstart[s] + a * w, 0, a, ldinv[c0 + a], c0, a, y)
        for a in range(w):
            base = bstart[s] + a * r
            for i in range(r):
                v = LB[base + i]
                row = R[r0 + i]
                if row < top:
                    for q in range(k):
                        y[row, q] -= v * y[c0 + a, q]
                else:
                    for q in range(k):
                        acc[row - top, q] += v * y[c0 + a, q]


@numba.njit(cache=True, nogil=True, fastmath=True, boundscheck=False)
def _backward_wide(starts, rstart, R, bstart, UB, dstart, UD, udinv, s_lo, s_hi, y):  # pragma: no cover
    """:func:`_backward` for ``y`` of shape (n, k)."""
    k = y.shape[1]
    t = np.empty(k, y.dtype)
    for s in range(s_hi - 1, s_lo - 1, -1):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        for a in range(w):
            base = bstart[s] + a * r
            for q in range(k):
                t[q] = 0.0
            for i in range(r):
                u = UB[base + i]
                row = R[r0 + i]
                for q in range(k):
                    t[q] += u * y[row, q]
            for q in range(k):
                y[c0 + a, q] -= t[q]
        for a in range(w - 1, -1, -1):
            _diag_row(UD, dstart[s] + a * w, a + 1, w, udinv[c0 + a], c0, a, y)


@numba.njit(parallel=True, cache=True, nogil=True, fastmath=True, boundscheck=False)
def _sweep_wide(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, split, y):  # pragma: no cover
    """:func:`_sweep3` for ``y`` of shape (n, k), any k."""
    n, k = y.shape
    ns = starts.shape[0] - 1
    if split[0] == 0:  # no cut: one thread, no buffers for the top
        _forward_wide(starts, rstart, R, bstart, LB, dstart, LD, ldinv, 0, ns, y, np.zeros((0, k), y.dtype), n)
        _backward_wide(starts, rstart, R, bstart, UB, dstart, UD, udinv, 0, ns, y)
        return
    top = starts[split[1]]
    acc = np.zeros((2, n - top, k), y.dtype)
    for part in numba.prange(2):
        s_lo, s_hi = _part(split, part)
        _forward_wide(starts, rstart, R, bstart, LB, dstart, LD, ldinv, s_lo, s_hi, y, acc[part], top)
    for i in range(n - top):
        for q in range(k):
            y[top + i, q] -= acc[0, i, q] + acc[1, i, q]
    _forward_wide(starts, rstart, R, bstart, LB, dstart, LD, ldinv, split[1], ns, y, acc[0], n)
    _backward_wide(starts, rstart, R, bstart, UB, dstart, UD, udinv, split[1], ns, y)
    for part in numba.prange(2):
        s_lo, s_hi = _part(split, part)
        _backward_wide(starts, rstart, R, bstart, UB, dstart, UD, udinv, s_lo, s_hi, y)


@numba.njit(cache=True, nogil=True)
def _transpose_blocks(starts, dstart, D, out):  # pragma: no cover - compiled
    """Every supernode's (w, w) diagonal block of ``D``, transposed into ``out``."""
    for s in range(starts.shape[0] - 1):
        w = starts[s + 1] - starts[s]
        d0 = dstart[s]
        for a in range(w):
            for e in range(w):
                out[d0 + a * w + e] = D[d0 + e * w + a]


@numba.njit(cache=True, nogil=True)
def _gather(B, perm, y):  # pragma: no cover - compiled
    """``y[q // 3, q % 3, i] = B[perm[i], q]``: the permuted right-hand sides, three per sweep."""
    n, k = B.shape
    for i in range(n):
        src = perm[i]
        for q in range(k):
            y[q // 3, q % 3, i] = B[src, q]


@numba.njit(cache=True, nogil=True)
def _scatter(y, perm, X):  # pragma: no cover - compiled
    """``X[perm[i], q] = y[q // 3, q % 3, i]``."""
    n, k = X.shape
    for i in range(n):
        dst = perm[i]
        for q in range(k):
            X[dst, q] = y[q // 3, q % 3, i]


class SupernodalFactor:
    """``A[perm][:, perm] = L U`` held as dense supernode blocks; ``solve`` back-substitutes.

    Build with :func:`lu_supernodal` or :func:`cholmod_supernodal`. Two threads
    sweep when :func:`tree_split` finds two subtrees and no stored entry of the
    first reaches into the second (``threads``).

    Parameters
    ----------
    L : (n, n) csc matrix
        The lower factor, diagonal included (rows in any order).
    U : (n, n) csc matrix or None
        The upper factor; None for a Cholesky factor (``U = L^T``: the
        off-diagonal blocks are shared).
    perm : (n,) int array
        ``P``: row ``i`` of the factored matrix is row ``perm[i]`` of ``A``.
    single : bool
        Keep the blocks in float32 (solutions float32, the caller refines).

    Raises
    ------
    Unsuitable
        An entry of ``U`` lies outside the pattern of ``L^T``, or a diagonal
        entry is zero or missing.

    Attributes
    ----------
    supernodes : int
    nnz : int
        Entries the sweeps read: both off-diagonal blocks and both full diagonal
        blocks of every supernode (a Cholesky factor's shared block counted twice).
    nbytes : int
    """

    name = "supernodal"

    def __init__(self, L: sp.csc_matrix, U: sp.csc_matrix | None, perm: np.ndarray, single: bool = False) -> None:
        n = L.shape[0]
        self.shape = (n, n)
        self.single = single
        self.dtype = np.float32 if single else np.float64
        self._perm = np.ascontiguousarray(perm, dtype=np.int64)
        Lp, Li = L.indptr.astype(np.int64), L.indices.astype(np.int64)
        first, below = _column_stats(Lp, Li)
        m1, m2 = tree_split(first, np.diff(Lp))
        starts = supernode_starts(Lp, first, (m1, m2))
        last = starts[1:] - 1
        r = below[last]  # rows below a supernode's block
        w = np.diff(starts)
        rstart = np.r_[0, np.cumsum(r)].astype(np.int64)
        bstart = np.r_[0, np.cumsum(r * w)].astype(np.int64)
        dstart = np.r_[0, np.cumsum(w * w)].astype(np.int64)
        R = np.empty(rstart[-1], np.int64)
        _rows_below(starts, Lp, Li, rstart, R)
        split = np.searchsorted(starts, [m1, m2]).astype(np.int64)
        # The tree comes from the stored pattern; an exported factor may have dropped exact zeros, so a
        # column of the first part could still reach into the second. Two threads only when none does.
        first_part = R[:rstart[split[0]]]
        if not (0 < m1 < m2) or np.any((first_part >= m1) & (first_part < m2)):
            split = np.zeros(2, np.int64)
        self._split = split
        self.threads = 2 if split[0] > 0 else 1
        triangles = [(Lp, Li, L.data.astype(np.float64))]
        if U is not None:
            triangles.append(_transpose(U.indptr.astype(np.int64), U.indices.astype(np.int64),
                                        U.data.astype(np.float64)))
        blocks: list[np.ndarray] = []
        for j, (Mp, Mi, Mx) in enumerate(triangles):
            B = np.zeros(bstart[-1])
            D = np.zeros(dstart[-1])
            dinv = np.zeros(n)
            if not _fill(starts, Mp, Mi, Mx, j == 0, rstart, R, bstart, dstart, B, D, dinv):
                raise Unsuitable("the factor's pattern does not fit its supernodes (an entry of U outside "
                                 "the pattern of L^T, or a zero on the diagonal)")
            if not np.all(dinv != 0.0):
                raise Unsuitable(f"the factor has no diagonal entry in {int(np.sum(dinv == 0.0))} columns")
            blocks += [B, D, dinv]
        if U is None:  # Cholesky, U = L^T: the same off-diagonal blocks, the diagonal blocks transposed
            LB, LD, ldinv = blocks
            UD = np.empty_like(LD)
            _transpose_blocks(starts, dstart, LD, UD)
            UB, udinv = LB, ldinv
        else:
            LB, LD, ldinv, UB, UD, udinv = blocks
        self._double: tuple[np.ndarray, ...] = (starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv)
        self._arrays: tuple[np.ndarray, ...] = self._double
        if single:
            cast = {id(a): a.astype(np.float32) for a in (LB, UB, LD, UD, ldinv, udinv)}  # shared ones stay shared
            self._arrays = (starts, rstart, R, bstart, cast[id(LB)], cast[id(UB)], dstart, cast[id(LD)],
                            cast[id(UD)], cast[id(ldinv)], cast[id(udinv)])
        self.supernodes = int(starts.size - 1)
        self.nnz = int(2 * bstart[-1] + 2 * dstart[-1])
        held = self.nnz - (bstart[-1] if U is None else 0) + (n if U is None else 2 * n)
        self.nbytes = int(held * np.dtype(self.dtype).itemsize + R.nbytes + 3 * starts.nbytes + self._perm.nbytes)

    @classmethod
    def from_blocks(cls, perm: np.ndarray, starts: np.ndarray, rstart: np.ndarray, R: np.ndarray, bstart: np.ndarray,
                    LB: np.ndarray, UB: np.ndarray, dstart: np.ndarray, LD: np.ndarray, UD: np.ndarray,
                    ldinv: np.ndarray, udinv: np.ndarray, split: np.ndarray, single: bool) -> SupernodalFactor:
        """A factor from blocks already laid out (:func:`~solver.linalg.multifrontal.lu_multifrontal`).

        The arrays are those the constructor builds (same names, same layout), in
        the factor's precision; no double-precision copy is kept.
        """
        f = cls.__new__(cls)
        n = int(starts[-1])
        f.shape = (n, n)
        f.single = single
        f.dtype = np.float32 if single else np.float64
        f._perm = np.ascontiguousarray(perm, dtype=np.int64)
        f._split = np.asarray(split, np.int64)
        f.threads = 2 if f._split[0] > 0 else 1
        f._arrays = (starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv)
        f._double = () if single else f._arrays
        f.supernodes = int(starts.size - 1)
        f.nnz = int(2 * bstart[-1] + 2 * dstart[-1])
        f.nbytes = int((f.nnz + 2 * n) * np.dtype(f.dtype).itemsize + R.nbytes + 3 * starts.nbytes + f._perm.nbytes)
        return f

    def _sweep(self, b: np.ndarray, arrays: tuple[np.ndarray, ...], dtype: type) -> np.ndarray:
        shape = np.shape(b)
        B = np.reshape(np.asarray(b, dtype=np.float64), (shape[0], -1))
        k = B.shape[1]
        starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv = arrays
        X = np.empty(B.shape)
        if k <= GROUPED_COLUMNS:  # three streams over each block row, three columns per sweep
            g = -(-k // 3)
            y: np.ndarray = np.zeros((g, 3, shape[0]), dtype)
            _gather(B, self._perm, y)
            for j in range(g):
                _sweep3(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, self._split, y[j])
            _scatter(y, self._perm, X)
        else:  # many columns: each factor entry read once for all of them
            Y: np.ndarray = np.ascontiguousarray(B[self._perm], dtype=dtype)
            _sweep_wide(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, self._split, Y)
            X[self._perm] = Y
        return X.reshape(shape)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b`` for ``b`` of shape (n,) or (n, k).

        Parameters
        ----------
        b : (n,) or (n, k) array

        Returns
        -------
        x : float64 array of ``b``'s shape (a single-precision factor's rounding in its values)
        """
        return self._sweep(b, self._arrays, self.dtype)

    def solve_double(self, b: np.ndarray) -> np.ndarray:
        """:meth:`solve` with the double-precision blocks (set-up probe; kept only while building)."""
        return self._sweep(b, self._double, np.float64)

    def drop_double(self) -> None:
        """Free the double-precision blocks of a single-precision factor once it has been probed."""
        if self.single:
            self._double = ()


def _probe(f: SupernodalFactor, A: sp.spmatrix) -> None:
    """Refuse a factor whose double-precision solve of a random right-hand side is not backward stable.

    The measure is the normwise backward error ``|A x - b| / (|A| |x| + |b|)``
    (infinity norms): about ``1e-16`` times a small factor for a stable solve,
    whatever ``A``'s condition; growth in an LU without pivoting shows up here.
    """
    rng = np.random.default_rng(7)
    b = rng.standard_normal((A.shape[0], 3))
    x = f.solve_double(b)
    norm_a = float(abs(sp.csr_matrix(A)).sum(axis=1).max())
    err = np.abs(A @ x - b).max() / max(norm_a * np.abs(x).max() + np.abs(b).max(), 1e-300)
    if not np.isfinite(err) or err > PROBE_TOL:
        raise Unsuitable(f"probe solve missed: backward error {err:.2e} > {PROBE_TOL:g}")
    f.drop_double()


def lu_supernodal(A: sp.spmatrix, single: bool = False) -> SupernodalFactor:
    """LU of a structurally symmetric, diagonally dominant matrix without pivoting, in supernodes.

    The ordering is PARDISO's METIS nested dissection of the symmetrized
    pattern (:func:`~solver.linalg.pardiso.nested_dissection`); SuperLU factors
    the ordered matrix in its natural order with diagonal pivots only. The
    ordering (a ctypes call) and the factorization release the GIL, so most of
    the work overlaps Python work on another thread; the exports, the layout's
    numpy steps and the probe's product do not.

    Parameters
    ----------
    A : (n, n) sparse matrix
    single : bool
        Keep the blocks in float32.

    Returns
    -------
    SupernodalFactor

    Raises
    ------
    Unsuitable
        SuperLU found a zero pivot or exchanged rows, the pattern is not
        structurally symmetric, or the probe solve missed.
    FactorizationError
        PARDISO's ordering failed.
    """
    import scipy.sparse.linalg as spla

    from .pardiso import nested_dissection

    A = sp.csc_matrix(A)
    perm = nested_dissection(A)
    Ap = sp.csc_matrix(A[perm][:, perm])
    try:
        lu = spla.splu(Ap, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError as e:
        raise Unsuitable(f"SuperLU without pivoting failed ({e})") from e
    n = A.shape[0]
    if not (np.array_equal(lu.perm_r, np.arange(n)) and np.array_equal(lu.perm_c, np.arange(n))):
        raise Unsuitable("SuperLU exchanged rows")
    f = SupernodalFactor(lu.L, lu.U, perm, single)
    _probe(f, A)
    return f


def cholmod_supernodal(factor: object, A: sp.spmatrix) -> SupernodalFactor:
    """A scikit-sparse CHOLMOD factor of ``A`` (``L L^T = A[P][:, P]``) laid out in supernodes.

    Raises
    ------
    Unsuitable
        The probe solve missed.
    """
    f = SupernodalFactor(factor.L(), None, factor.P())  # type: ignore[attr-defined]
    _probe(f, A)
    return f
