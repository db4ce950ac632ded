"""Multifrontal LU without pivoting, written straight into the supernode blocks of the sweeps.

For square systems too large for SuperLU's factorization (the 1M-tet
meshes' interior mean-value system), this factors ``A[P][:, P] = L U``
itself and lays the factor out as :class:`~solver.linalg.supernodal.SupernodalFactor`
blocks, so the update's back-substitution is the supernodal sweep, not
PARDISO's solve phase.

The steps (Duff & Reid's multifrontal method on the elimination tree of the
symmetrized pattern; Liu, "The multifrontal method for sparse matrix
solution", SIAM Review 34, 1992):

1. ``P``: PARDISO's nested-dissection ordering (phase 11 only), then a
   postorder of the elimination tree of ``|A| + |A|^T``, so every subtree is
   a contiguous range of columns and children come before parents.
2. Column counts of ``L`` by row subtrees, fundamental supernodes (cut at
   the two-subtree split of :func:`~solver.linalg.supernodal.tree_split`),
   and every supernode's rows below its diagonal block ``R`` (its own entries
   of ``A`` and its children's ``R``).
3. Per supernode, in postorder: a dense front over its columns and ``R``,
   assembled from ``A`` and the children's update matrices (extend-add); a
   partial LU of its first ``w`` pivots in blocks of :data:`PANEL` columns,
   the triangular solves and the trailing update by BLAS (``dtrsm``,
   ``dgemm``, called without the GIL); the
   blocks copied out and the Schur complement kept for the parent.

A single-precision factor is computed in single precision (``sgemm``,
``strsm``), as PARDISO's ``iparm(28) = 1`` factor is: half the bytes and
twice the arithmetic rate of double; the update's double-precision residual
check and refinement step (:mod:`solver.deform.positions`) stand behind it
as they stand behind PARDISO's. ``single=False`` keeps every step in double
precision. The two subtrees under the top
separator are factored on two threads (one BLAS thread each), the top with
``threads`` BLAS threads. BLAS is MKL's where it is installed (its thread
count is set per calling thread), else SciPy's OpenBLAS. The tree walks and
the fronts are compiled kernels in ``src/core/multifrontal.cpp``.

There is no pivoting: the mean-value systems this serves have ``1`` on the
diagonal and minus convex weights elsewhere in every row. A zero or
non-finite pivot is refused with :class:`~solver.linalg.supernodal.Unsuitable`,
and so is a factor whose probe solve misses its backward-error bound; the
caller then keeps PARDISO, which pivots.
"""

from __future__ import annotations

import threading

import numpy as np
import scipy.sparse as sp
import tetmorph_core

from ..errors import FactorizationError
from .supernodal import SupernodalFactor, Unsuitable, supernode_starts, tree_split

__all__ = ["lu_multifrontal", "symbolic", "postordered", "PANEL", "RELAX", "SINGLE_PROBE_TOL"]

#: Pivot columns per blocked step of a front's partial LU.
PANEL = 64
#: Normwise backward error a single-precision factor's probe solve must meet
#: (float32 rounding of a stable factor is about 1e-7 of it).
SINGLE_PROBE_TOL = 1e-5
#: Normwise backward error of a double-precision factor's probe (as the supernodal module's).
DOUBLE_PROBE_TOL = 1e-12
#: Relaxed supernodes: a child merges into its parent while the merged supernode has at most
#: ``RELAX[k][0]`` columns and at most ``RELAX[k][1]`` of its stored lower entries are explicit
#: zeros (the first rule met; CHOLMOD's default relaxation has the same shape). Wider blocks
#: mean fewer, longer inner loops in the sweeps and fewer, larger BLAS calls in the fronts.
RELAX = ((4, 1.0), (16, 0.8), (48, 0.1), (1 << 62, 0.05))


def _blas() -> tetmorph_core.Mkl | None:
    """MKL's runtime when installed (its BLAS takes a thread count per calling thread), else None."""
    from .pardiso import _library

    try:
        return _library()
    except FactorizationError:  # not installed, or a broken install: SciPy's BLAS
        return None


def _hand_over_blas(lib: tetmorph_core.Mkl | None) -> None:
    """Have the compiled fronts call ``lib``'s ``dgemm``, ``sgemm``, ``dtrsm``, ``strsm``; None: SciPy's."""
    tetmorph_core.multifrontal_use_blas(*((0, 0, 0, 0) if lib is None else lib.blas()))


# The fronts' BLAS: MKL's, whose thread count is set per calling thread (the two subtrees then run
# one BLAS thread each without touching another thread's calls), handed to the compiled kernel by
# address; without MKL the kernel calls SciPy's OpenBLAS (scipy.linalg.cython_blas's).
_MKL = _blas()
_hand_over_blas(_MKL)


# ---------------------------------------------------------------------------------------------- symbolic


def _etree(Sp: np.ndarray, Si: np.ndarray) -> np.ndarray:
    """Elimination tree of a symmetric pattern (CSC, both triangles): (n,) int64 parents, -1 for a root."""
    parent = np.empty(Sp.shape[0] - 1, np.int64)
    tetmorph_core.multifrontal_etree(Sp, Si, parent)
    return parent


def _postorder(parent: np.ndarray) -> np.ndarray:
    """A postorder of a forest given by ``parent`` (children in increasing order): ``post[k]`` is the k-th node."""
    post = np.empty(parent.shape[0], np.int64)
    tetmorph_core.multifrontal_postorder(parent, post)
    return post


def _column_counts(Sp: np.ndarray, Si: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Entries of every column of ``L`` (diagonal included), by the row subtrees of the elimination tree."""
    count = np.empty(Sp.shape[0] - 1, np.int64)
    tetmorph_core.multifrontal_column_counts(Sp, Si, parent, count)
    return count


def _amalgamate(starts: np.ndarray, sparent: np.ndarray, count: np.ndarray, fixed: np.ndarray,
                relax: np.ndarray) -> np.ndarray:
    """Which supernode starts survive relaxed merging (:data:`RELAX`); ``fixed[s]``: ``s`` must start one.

    Supernode ``s`` merges into ``s + 1`` when that is its parent (postorder puts a
    last child just before its parent): the merged block keeps the parent's rows
    below, so the child's columns gain explicit zeros. Merges chain upward.

    Returns
    -------
    keep : (s,) bool array
    """
    keep = np.empty(starts.shape[0] - 1, np.bool_)
    tetmorph_core.multifrontal_amalgamate(starts, sparent, count, fixed, relax, keep)
    return keep


def _stack_peak(s_lo: int, s_hi: int, rstart: np.ndarray, nchild: np.ndarray, sizes0: np.ndarray) -> int:
    """Most values the update-matrix stack holds while ``s_lo..s_hi-1`` are factored.

    ``sizes0``: the sizes of the update matrices on the stack before the first.
    """
    return int(tetmorph_core.multifrontal_stack_peak(s_lo, s_hi, rstart, nchild, sizes0))


class Symbolic:
    """The ordering and supernode structure of one multifrontal LU (:func:`symbolic`).

    Attributes
    ----------
    perm : (n,) int64 array
        Row ``i`` of the factored matrix is row ``perm[i]`` of ``A``.
    starts : (s + 1,) int64 array
        First column of every supernode, ``n`` last.
    sparent : (s,) int64 array
        Parent supernode (-1 for a root).
    rstart, R : int64 arrays
        Rows below supernode ``s``'s diagonal block: ``R[rstart[s]:rstart[s + 1]]``, sorted.
    split : (2,) int64 array
        Supernodes ``[0, split[0])`` and ``[split[0], split[1])`` are two disjoint subtrees;
        ``(0, 0)`` when there is no such cut.
    """

    def __init__(self, perm: np.ndarray, starts: np.ndarray, sparent: np.ndarray, rstart: np.ndarray,
                 R: np.ndarray, split: np.ndarray) -> None:
        self.perm, self.starts, self.sparent, self.rstart, self.R, self.split = perm, starts, sparent, rstart, R, split

    @property
    def nnz(self) -> int:
        """Entries of ``L`` and ``U`` together (full diagonal blocks counted once per factor)."""
        w = np.diff(self.starts)
        r = np.diff(self.rstart)
        return int(2 * (w * r).sum() + 2 * (w * w).sum())


def _pattern(A: sp.csc_matrix) -> tuple[np.ndarray, np.ndarray]:
    """CSC pointers and rows of the pattern of ``|A| + |A|^T`` (sorted, no values)."""
    P = sp.csc_matrix((np.ones(A.nnz, np.int8), A.indices, A.indptr), shape=A.shape)
    S = (P + P.T).tocsc()
    S.sort_indices()
    return S.indptr.astype(np.int64), S.indices.astype(np.int64)


def postordered(A: sp.spmatrix, perm: np.ndarray) -> np.ndarray:
    """``perm`` followed by a postorder of the elimination tree of ``A[perm][:, perm]``.

    The fill is the same; each subtree's columns become contiguous, so that
    supernodes are found whole.

    Parameters
    ----------
    A : (n, n) sparse matrix
        Its pattern symmetrized (``|A| + |A|^T``).
    perm : (n,) int array

    Returns
    -------
    (n,) int64 array
    """
    perm = np.asarray(perm, np.int64)
    Sp, Si = _pattern(sp.csc_matrix(A[perm][:, perm]))
    return perm[_postorder(_etree(Sp, Si))]


def _super_parents(starts: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Parent supernode of every supernode (-1 for a root): the one holding its last column's parent."""
    ns = starts.size - 1
    col_super = np.repeat(np.arange(ns), np.diff(starts))
    last_parent = parent[starts[1:] - 1]
    return np.where(last_parent >= 0, col_super[np.maximum(last_parent, 0)], -1).astype(np.int64)


def symbolic(A: sp.spmatrix, perm: np.ndarray | None = None, relax: bool = True) -> Symbolic:
    """Ordering, elimination tree, supernodes and row sets of the LU of ``A`` without pivoting.

    Parameters
    ----------
    A : (n, n) sparse matrix
    perm : (n,) int array, optional
        A fill-reducing ordering (default: PARDISO's nested dissection); it is
        refined by a postorder of its elimination tree, which keeps the fill.
    relax : bool
        Merge small supernodes into their parents (:data:`RELAX`); False keeps
        the fundamental supernodes (no explicit zeros).

    Returns
    -------
    Symbolic

    Raises
    ------
    Unsuitable
        The row sets disagree with the column counts (a defect, never expected).
    """
    from .pardiso import nested_dissection

    A = sp.csc_matrix(A)
    n = A.shape[0]
    if perm is None:
        perm = nested_dissection(A)
    perm = postordered(A, perm)
    Sp, Si = _pattern(sp.csc_matrix(A[perm][:, perm]))
    parent = _etree(Sp, Si)
    count = _column_counts(Sp, Si, parent)
    m1, m2 = tree_split(parent, count)
    Lp = np.r_[0, np.cumsum(count)].astype(np.int64)
    breaks = (m1, m2) if 0 < m1 < m2 else ()
    starts = supernode_starts(Lp, parent, breaks)
    sparent = _super_parents(starts, parent)
    if relax:
        fixed = np.isin(starts[:-1], np.array(breaks, np.int64))
        keep = _amalgamate(starts, sparent, count, fixed, np.array(RELAX, np.float64))
        starts = np.r_[starts[:-1][keep], n].astype(np.int64)
        sparent = _super_parents(starts, parent)
    r = count[starts[1:] - 1] - 1  # a supernode's rows below are its last column's
    rstart = np.r_[0, np.cumsum(r)].astype(np.int64)
    R = np.empty(rstart[-1], np.int64)
    if not tetmorph_core.multifrontal_rows_below(starts, sparent, Sp, Si, rstart, R):
        raise Unsuitable("the supernodes' row sets disagree with the column counts")
    split = np.searchsorted(starts, [m1, m2]).astype(np.int64) if 0 < m1 < m2 else np.zeros(2, np.int64)
    return Symbolic(perm, starts, sparent, rstart, R, split)


# ---------------------------------------------------------------------------------------------- numeric


class _Stack:
    """One update-matrix stack (:func:`_factor_range`), sized for a range of supernodes."""

    buf: np.ndarray
    ent_s: np.ndarray
    ent_off: np.ndarray
    top: int

    def __init__(self, s_lo: int, s_hi: int, rstart: np.ndarray, nchild: np.ndarray,
                 carried: list[tuple[_Stack, int]] | None = None, dtype: type = np.float64) -> None:
        pending = carried or []
        sizes0 = np.array([int(np.diff(rstart)[st.ent_s[q]]) ** 2 for st, q in pending], np.int64)
        self.buf = np.empty(max(1, _stack_peak(s_lo, s_hi, rstart, nchild, sizes0)), dtype)
        self.ent_s = np.zeros(len(pending) + s_hi - s_lo, np.int64)
        self.ent_off = np.zeros_like(self.ent_s)
        off = 0
        for j, (st, q) in enumerate(pending):  # the carried update matrices first, in their order
            size = int(sizes0[j])
            self.buf[off:off + size] = st.buf[st.ent_off[q]:st.ent_off[q] + size]
            self.ent_s[j], self.ent_off[j] = st.ent_s[q], off
            off += size
        self.top = len(pending)


def lu_multifrontal(A: sp.spmatrix, single: bool = False, sym: Symbolic | None = None,
                    threads: int = 2) -> SupernodalFactor:
    """LU of a structurally symmetric, diagonally dominant matrix without pivoting, as supernode blocks.

    Parameters
    ----------
    A : (n, n) sparse matrix
    single : bool
        Factor in single precision and store the blocks in float32.
    sym : Symbolic, optional
        The structure from :func:`symbolic` (computed when not given).
    threads : int
        2: the two subtrees under the top separator on two threads; 1: one.

    Returns
    -------
    SupernodalFactor

    Raises
    ------
    Unsuitable
        A zero or non-finite pivot, or a probe solve that misses its bound.
    FactorizationError
        PARDISO's ordering failed.
    """
    A = sp.csc_matrix(A, dtype=np.float64)
    dt = np.float32 if single else np.float64
    if sym is None:
        sym = symbolic(A)
    perm = sym.perm
    Ap = sp.csc_matrix(A[perm][:, perm])
    Ap.sort_indices()
    At = sp.csc_matrix(Ap.T)
    At.sort_indices()
    starts, rstart, R, sparent, split = sym.starts, sym.rstart, sym.R, sym.sparent, sym.split
    w = np.diff(starts)
    r = np.diff(rstart)
    bstart = np.r_[0, np.cumsum(w * r)].astype(np.int64)
    dstart = np.r_[0, np.cumsum(w * w)].astype(np.int64)
    LB, UB = np.zeros(bstart[-1], dt), np.zeros(bstart[-1], dt)
    LD, UD = np.zeros(dstart[-1], dt), np.zeros(dstart[-1], dt)
    udinv = np.zeros(starts[-1], dt)
    ns = starts.size - 1
    nchild = np.bincount(sparent[sparent >= 0], minlength=ns).astype(np.int64)
    args = (starts, rstart, R, nchild, Ap.indptr.astype(np.int64), Ap.indices.astype(np.int64), Ap.data.astype(dt),
            At.indptr.astype(np.int64), At.indices.astype(np.int64), At.data.astype(dt), bstart, dstart,
            LB, UB, LD, UD, udinv)
    fronts = (w + r) ** 2
    bad: list[int] = []

    def run(lo: int, hi: int, st: _Stack, blas_threads: int) -> None:
        prev = _MKL.set_local_threads(blas_threads) if _MKL is not None else 0
        try:
            got, st.top = tetmorph_core.multifrontal_factor_range(
                lo, hi, *args, st.buf, st.ent_s, st.ent_off, st.top, np.empty(int(fronts[lo:hi].max(initial=1)), dt),
                PANEL)
        finally:
            if _MKL is not None:
                _MKL.set_local_threads(prev)
        if got >= 0:
            bad.append(int(got))

    carried: list[tuple[_Stack, int]] = []
    lo = 0
    if threads > 1 and split[0] > 0:  # the two subtrees at once, then the top
        parts = [(0, int(split[0])), (int(split[0]), int(split[1]))]
        stacks = [_Stack(a, b, rstart, nchild, None, dt) for a, b in parts]
        t = threading.Thread(target=run, args=(*parts[1], stacks[1], 1), name="tetmorph-lu-subtree")
        t.start()  # two BLAS callers at once: one BLAS thread each
        run(*parts[0], stacks[0], 1)
        t.join()
        carried = [(st, q) for st in stacks for q in range(st.top)]
        lo = int(split[1])
    if not bad:
        run(lo, ns, _Stack(lo, ns, rstart, nchild, carried, dt), threads)
    if bad:
        raise Unsuitable(f"LU without pivoting met a zero or non-finite pivot in supernode {min(bad)}")
    ldinv = np.ones(starts[-1], dt)
    f = SupernodalFactor.from_blocks(perm, starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv,
                                     split, single)
    _probe(f, A, SINGLE_PROBE_TOL if single else DOUBLE_PROBE_TOL)
    return f


def _probe(f: SupernodalFactor, A: sp.csc_matrix, tol: float) -> None:
    """Refuse a factor whose solve of a random right-hand side misses normwise backward error ``tol``."""
    rng = np.random.default_rng(7)
    b = rng.standard_normal((A.shape[0], 3))
    x = f.solve(b)
    norm_a = float(abs(A).sum(axis=1).max())
    err = np.abs(A @ x - b).max() / max(norm_a * np.abs(x).max() + np.abs(b).max(), 1e-300)
    if not np.isfinite(err) or err > tol:
        raise Unsuitable(f"probe solve missed: backward error {err:.2e} > {tol:g}")
