"""Supernodal back-substitution over an exported LU or Cholesky factor, for systems up to medium size.

A factor is cut into supernodes: runs of consecutive columns ``c0..c1-1`` of
``L`` that share one row pattern ``R`` below their diagonal block (and, the
pattern being symmetric, rows of ``U`` that share the column pattern ``R``).
Each supernode keeps four dense blocks, row-major: the strictly lower part of
``L[c0:c1, c0:c1]``, the strictly upper part of ``U[c0:c1, c0:c1]``,
``L[R, c0:c1]^T`` and ``U[c0:c1, R]``, and one index array ``R``. A
back-substitution then reads every value once per sweep as a contiguous
stream (no index per entry) and touches the right-hand side through ``R``
once per supernode. The sweeps are the kernels of :mod:`solver.linalg.sweeps`;
this module lays a factor out for them (its index work in compiled kernels of
``src/core/sweeps.cpp``).

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

import numpy as np
import scipy.sparse as sp
import tetmorph_core

from .sweeps import _gather, _scatter, _sweep3, _sweep_wide

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


def _subtrees(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Size and smallest column of every column's subtree (parents come after their children).

    Parameters
    ----------
    parent : (n,) int64 array
        Parent of every column (-1 for a root).

    Returns
    -------
    size, lo : (n,) int64 arrays
    """
    size = np.empty(parent.size, np.int64)
    lo = np.empty(parent.size, np.int64)
    tetmorph_core.supernodal_subtrees(parent, size, lo)
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


def _column_stats(Lp: np.ndarray, Li: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First row below the diagonal of every column (-1 when none) and how many rows lie below it.

    Parameters
    ----------
    Lp, Li : int64 arrays
        CSC column pointers (n + 1,) and row indices of ``L``.

    Returns
    -------
    first, below : (n,) int64 arrays
    """
    n = Lp.size - 1
    first = np.empty(n, np.int64)
    below = np.empty(n, np.int64)
    tetmorph_core.supernodal_column_stats(Lp, Li, first, below)
    return first, below


def _transpose(Up: np.ndarray, Ui: np.ndarray, Ux: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSC of ``U^T`` (the rows of ``U``) from the CSC of ``U``, by a counting sort.

    Parameters
    ----------
    Up, Ui : int64 arrays
        CSC column pointers (n + 1,) and row indices (nnz,) of ``U``.
    Ux : (nnz,) float64 array

    Returns
    -------
    Tp : (n + 1,) int64 array
    Ti : (nnz,) int64 array
    Tx : (nnz,) float64 array
    """
    nnz = int(Up[-1])
    Tp = np.empty(Up.size, np.int64)
    Ti = np.empty(nnz, np.int64)
    Tx = np.empty(nnz, np.float64)
    tetmorph_core.supernodal_transpose(Up, Ui, Ux, Tp, Ti, Tx)
    return Tp, Ti, Tx


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
        tetmorph_core.supernodal_rows_below(starts, Lp, Li, rstart, R)
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
            if not tetmorph_core.supernodal_fill(starts, Mp, Mi, Mx, j == 0, rstart, R, bstart, dstart, B, D, dinv):
                raise Unsuitable("the factor's pattern does not fit its supernodes (an entry of U outside "
                                 "the pattern of L^T, or a zero on the diagonal)")
            if not np.all(dinv != 0.0):
                raise Unsuitable(f"the factor has no diagonal entry in {int(np.sum(dinv == 0.0))} columns")
            blocks += [B, D, dinv]
        if U is None:  # Cholesky, U = L^T: the same off-diagonal blocks, the diagonal blocks transposed
            LB, LD, ldinv = blocks
            UD = np.empty_like(LD)
            tetmorph_core.supernodal_transpose_blocks(starts, dstart, LD, UD)
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
    ordering (a compiled call) and the factorization release the GIL, so most of
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
