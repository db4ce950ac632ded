"""Supernodal back-substitution over an exported LU factor, for mean-value systems up to medium size.

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

Why not PARDISO's own solve: at the size of the 107k-tet bracket's interior
(12,892 unknowns, 2.8M factor entries, three right-hand sides) PARDISO's
phase 33 takes about 5 ms in single or double precision, on one thread or
two, whatever its solve settings -- several times the bytes it reads at this
machine's bandwidth -- and the sweeps here less than half of that
(``benchmarks/measure_choices.py --only supernodal``). The 1M meshes' factors
stay with PARDISO, whose solve is near its memory-traffic floor there and
uses both cores (:data:`~solver.linalg.factorization.SUPERNODAL_MAX`).

The factor comes from SuperLU without pivoting on PARDISO's METIS ordering:
the mean-value systems are diagonally dominant (every row is ``1`` on the
diagonal and minus convex weights elsewhere). A factor that needed a row
exchange, whose pattern is not structurally symmetric, or whose probe solve
misses a relative residual of :data:`PROBE_TOL` is refused with
:class:`Unsuitable`, and the caller falls back to PARDISO, which pivots.

Every solve allocates its own work arrays: one factor serves concurrent
solves without a lock.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

__all__ = ["SupernodalFactor", "Unsuitable", "supernode_starts", "lu_supernodal"]

#: Relative residual a probe solve (in double precision) must meet at set-up.
PROBE_TOL = 1e-10


class Unsuitable(Exception):
    """The factor cannot be laid out in supernodes here (the caller uses its own backend)."""


def supernode_starts(indptr: np.ndarray, first: np.ndarray) -> np.ndarray:
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

    Returns
    -------
    (s + 1,) int64 array
    """
    n = indptr.size - 1
    cnt = np.diff(indptr)
    join = np.zeros(n, bool)
    j = np.arange(n - 1)
    join[1:] = (first[:-1] == j + 1) & (cnt[:-1] == cnt[1:] + 1)
    return np.r_[np.flatnonzero(~join), n].astype(np.int64)


@numba.njit(cache=True, nogil=True)
def _column_stats(Lp, Li):  # pragma: no cover - compiled
    """First row below the diagonal of every column (-1 when none); rows need not be sorted."""
    n = Lp.shape[0] - 1
    first = np.full(n, -1, np.int64)
    for c in range(n):
        m = n
        for p in range(Lp[c], Lp[c + 1]):
            r = Li[p]
            if c < r < m:
                m = r
        if m < n:
            first[c] = m
    return first


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


@numba.njit(cache=True, nogil=True, fastmath=True, boundscheck=False)
def _sweep3(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, y):  # pragma: no cover - compiled
    """``y <- U^{-1} L^{-1} y`` for three right-hand sides, ``y`` of shape (3, n)."""
    ns = starts.shape[0] - 1
    maxr = 0
    for s in range(ns):
        maxr = max(maxr, rstart[s + 1] - rstart[s])
    t = np.empty((3, maxr), y.dtype)
    z = y.dtype.type(0.0)
    for s in range(ns):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        d0 = dstart[s]
        b0 = bstart[s]
        for a in range(w):
            a0 = z
            a1 = z
            a2 = z
            base = d0 + a * w
            for e in range(a):
                v = LD[base + e]
                a0 += v * y[0, c0 + e]
                a1 += v * y[1, c0 + e]
                a2 += v * y[2, c0 + e]
            g = ldinv[c0 + a]
            y[0, c0 + a] = (y[0, c0 + a] - a0) * g
            y[1, c0 + a] = (y[1, c0 + a] - a1) * g
            y[2, c0 + a] = (y[2, c0 + a] - a2) * g
        if r:
            for i in range(r):
                t[0, i] = z
                t[1, i] = z
                t[2, i] = z
            for a in range(w):
                y0 = y[0, c0 + a]
                y1 = y[1, c0 + a]
                y2 = y[2, c0 + a]
                base = b0 + a * r
                for i in range(r):
                    v = LB[base + i]
                    t[0, i] += y0 * v
                    t[1, i] += y1 * v
                    t[2, i] += y2 * v
            for i in range(r):
                k = R[r0 + i]
                y[0, k] -= t[0, i]
                y[1, k] -= t[1, i]
                y[2, k] -= t[2, i]
    for s in range(ns - 1, -1, -1):
        c0 = starts[s]
        w = starts[s + 1] - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        d0 = dstart[s]
        b0 = bstart[s]
        if r:
            for i in range(r):
                k = R[r0 + i]
                t[0, i] = y[0, k]
                t[1, i] = y[1, k]
                t[2, i] = y[2, k]
            for a in range(w):
                base = b0 + a * r
                a0 = z
                a1 = z
                a2 = z
                for i in range(r):
                    u = UB[base + i]
                    a0 += u * t[0, i]
                    a1 += u * t[1, i]
                    a2 += u * t[2, i]
                y[0, c0 + a] -= a0
                y[1, c0 + a] -= a1
                y[2, c0 + a] -= a2
        for a in range(w - 1, -1, -1):
            a0 = z
            a1 = z
            a2 = z
            base = d0 + a * w
            for e in range(a + 1, w):
                v = UD[base + e]
                a0 += v * y[0, c0 + e]
                a1 += v * y[1, c0 + e]
                a2 += v * y[2, c0 + e]
            g = udinv[c0 + a]
            y[0, c0 + a] = (y[0, c0 + a] - a0) * g
            y[1, c0 + a] = (y[1, c0 + a] - a1) * g
            y[2, c0 + a] = (y[2, c0 + a] - a2) * g


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

    Build with :func:`lu_supernodal`.

    Parameters
    ----------
    L, U : (n, n) csc matrices
        The lower and upper factors, diagonals included (rows in any order).
    perm : (n,) int array
        ``P``: row ``i`` of the factored matrix is row ``perm[i]`` of ``A``.
    single : bool
        Keep the blocks in float32 (solutions float32, the caller refines).

    Raises
    ------
    Unsuitable
        An entry of ``U`` lies outside the pattern of ``L^T`` (not structurally
        symmetric), or a diagonal entry is zero.

    Attributes
    ----------
    supernodes : int
    nnz : int
        Entries held in the blocks (explicit zeros of the diagonal blocks included).
    nbytes : int
    """

    name = "supernodal"

    def __init__(self, L: sp.csc_matrix, U: sp.csc_matrix, perm: np.ndarray, single: bool = False) -> None:
        n = L.shape[0]
        self.shape = (n, n)
        self.single = single
        self.dtype = np.float32 if single else np.float64
        self._perm = np.ascontiguousarray(perm, dtype=np.int64)
        Lp, Li = L.indptr.astype(np.int64), L.indices.astype(np.int64)
        starts = supernode_starts(Lp, _column_stats(Lp, Li))
        last = starts[1:] - 1
        r = Lp[last + 1] - Lp[last] - 1  # rows below a supernode's block
        w = np.diff(starts)
        rstart = np.r_[0, np.cumsum(r)].astype(np.int64)
        bstart = np.r_[0, np.cumsum(r * w)].astype(np.int64)
        dstart = np.r_[0, np.cumsum(w * w)].astype(np.int64)
        R = np.empty(rstart[-1], np.int64)
        _rows_below(starts, Lp, Li, rstart, R)
        Tp, Ti, Tx = _transpose(U.indptr.astype(np.int64), U.indices.astype(np.int64), U.data.astype(np.float64))
        blocks: list[np.ndarray] = []
        for (Mp, Mi, Mx), lower in (((Lp, Li, L.data.astype(np.float64)), True), ((Tp, Ti, Tx), False)):
            B = np.zeros(bstart[-1])
            D = np.zeros(dstart[-1])
            dinv = np.zeros(n)
            if not _fill(starts, Mp, Mi, Mx, lower, rstart, R, bstart, dstart, B, D, dinv):
                raise Unsuitable("the factor's pattern does not fit its supernodes (not structurally symmetric)")
            blocks += [B, D, dinv]
        LB, LD, ldinv, UB, UD, udinv = blocks
        self._double: tuple[np.ndarray, ...] = (starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv)
        self._arrays: tuple[np.ndarray, ...] = self._double if not single else (
            starts, rstart, R, bstart, *(a.astype(np.float32) for a in (LB, UB)), dstart,
            *(a.astype(np.float32) for a in (LD, UD, ldinv, udinv)))
        self.supernodes = int(starts.size - 1)
        self.nnz = int(2 * bstart[-1] + 2 * dstart[-1])
        self.nbytes = int((self.nnz + 2 * n) * np.dtype(self.dtype).itemsize + R.nbytes + 3 * starts.nbytes
                          + self._perm.nbytes)

    def _sweep(self, b: np.ndarray, arrays: tuple[np.ndarray, ...], dtype: type) -> np.ndarray:
        shape = np.shape(b)
        B = np.reshape(np.asarray(b, dtype=np.float64), (shape[0], -1))
        g = -(-B.shape[1] // 3)
        y: np.ndarray = np.zeros((g, 3, shape[0]), dtype)
        _gather(B, self._perm, y)
        starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv = arrays
        for j in range(g):
            _sweep3(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, y[j])
        X = np.empty(B.shape)
        _scatter(y, self._perm, X)
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
    rng = np.random.default_rng(7)
    b = rng.standard_normal((A.shape[0], 3))
    x = f.solve_double(b)
    res = np.abs(A @ x - b).max() / max(np.abs(b).max(), 1e-300)
    if not np.isfinite(res) or res > PROBE_TOL:
        raise Unsuitable(f"probe solve missed: relative residual {res:.2e} > {PROBE_TOL:g}")
    f.drop_double()


def lu_supernodal(A: sp.spmatrix, single: bool = False) -> SupernodalFactor:
    """LU of a structurally symmetric, diagonally dominant matrix without pivoting, in supernodes.

    The ordering is PARDISO's METIS nested dissection of the symmetrized
    pattern (:func:`~solver.linalg.pardiso.nested_dissection`); SuperLU factors
    the ordered matrix in its natural order with diagonal pivots only. Every
    step but two short scipy conversions runs without the GIL, so the
    factorization overlaps Python work on another thread.

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
