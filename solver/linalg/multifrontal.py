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
count is set per calling thread), else SciPy's OpenBLAS.

There is no pivoting: the mean-value systems this serves have ``1`` on the
diagonal and minus convex weights elsewhere in every row. A zero or
non-finite pivot is refused with :class:`~solver.linalg.supernodal.Unsuitable`,
and so is a factor whose probe solve misses its backward-error bound; the
caller then keeps PARDISO, which pivots.
"""

from __future__ import annotations

import ctypes
import threading

import llvmlite.binding as llvm
import numba
import numpy as np
import scipy.sparse as sp
from numba.core import types
from numba.extending import get_cython_function_address

from .supernodal import SupernodalFactor, Unsuitable, supernode_starts, tree_split
from .threads import mkl_local_threads

__all__ = ["lu_multifrontal", "symbolic", "PANEL", "RELAX", "SINGLE_PROBE_TOL"]

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



def _blas() -> ctypes.CDLL | None:
    """MKL's runtime when installed (its BLAS takes a thread count per calling thread), else None."""
    from .pardiso import mkl_runtime

    path = mkl_runtime()
    try:
        return ctypes.CDLL(path) if path else None
    except OSError:  # pragma: no cover - a broken MKL install
        return None


# BLAS for numba by symbol name (a named external function keeps the kernels cacheable; a ctypes
# pointer would not): MKL's, whose thread count is set per calling thread (the two subtrees
# then run one BLAS thread each without touching another thread's calls), else SciPy's OpenBLAS.
# Every argument is an address, passed as a 64-bit integer.
_MKL = _blas()
for _name in ("dgemm", "dtrsm", "sgemm", "strsm"):
    _addr = (ctypes.cast(getattr(_MKL, _name), ctypes.c_void_p).value if _MKL is not None else
             get_cython_function_address("scipy.linalg.cython_blas", _name))
    llvm.add_symbol(f"tetmorph_{_name}", _addr)
_dgemm = types.ExternalFunction("tetmorph_dgemm", types.void(*([types.int64] * 13)))
_dtrsm = types.ExternalFunction("tetmorph_dtrsm", types.void(*([types.int64] * 11)))
_sgemm = types.ExternalFunction("tetmorph_sgemm", types.void(*([types.int64] * 13)))
_strsm = types.ExternalFunction("tetmorph_strsm", types.void(*([types.int64] * 11)))


# ---------------------------------------------------------------------------------------------- symbolic


@numba.njit(cache=True, nogil=True)
def _etree(Sp, Si):  # pragma: no cover - compiled
    """Elimination tree of a symmetric pattern (CSC, both triangles): Liu's algorithm with path compression."""
    n = Sp.shape[0] - 1
    parent = np.full(n, -1, np.int64)
    anc = np.full(n, -1, np.int64)
    for j in range(n):
        for p in range(Sp[j], Sp[j + 1]):
            i = Si[p]
            while i != -1 and i < j:
                nxt = anc[i]
                anc[i] = j
                if nxt == -1:
                    parent[i] = j
                i = nxt
    return parent


@numba.njit(cache=True, nogil=True)
def _postorder(parent):  # pragma: no cover - compiled
    """A postorder of a forest given by ``parent`` (children in increasing order): ``post[k]`` is the k-th node."""
    n = parent.shape[0]
    head = np.full(n, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    for j in range(n - 1, -1, -1):  # child lists in increasing order
        p = parent[j]
        if p >= 0:
            nxt[j] = head[p]
            head[p] = j
    post = np.empty(n, np.int64)
    stack = np.empty(n, np.int64)
    k = 0
    for root in range(n):
        if parent[root] != -1:
            continue
        top = 0
        stack[0] = root
        while top >= 0:
            v = stack[top]
            c = head[v]
            if c == -1:
                top -= 1
                post[k] = v
                k += 1
            else:
                head[v] = nxt[c]
                top += 1
                stack[top] = c
    return post


@numba.njit(cache=True, nogil=True)
def _column_counts(Sp, Si, parent):  # pragma: no cover - compiled
    """Entries of every column of ``L`` (diagonal included), by the row subtrees of the elimination tree."""
    n = Sp.shape[0] - 1
    count = np.ones(n, np.int64)
    mark = np.full(n, -1, np.int64)
    for i in range(n):
        mark[i] = i
        for p in range(Sp[i], Sp[i + 1]):
            k = Si[p]
            if k >= i:
                continue
            while mark[k] != i:  # L[i, k] and the path up to the row subtree's visited part
                count[k] += 1
                mark[k] = i
                k = parent[k]
    return count


@numba.njit(cache=True, nogil=True)
def _amalgamate(starts, sparent, count, fixed, relax):  # pragma: no cover - compiled
    """Which supernode starts survive relaxed merging (:data:`RELAX`); ``fixed[s]``: ``s`` must start one.

    Supernode ``s`` merges into ``s + 1`` when that is its parent (postorder puts a
    last child just before its parent): the merged block keeps the parent's rows
    below, so the child's columns gain explicit zeros. Merges chain upward.
    """
    ns = starts.shape[0] - 1
    keep = np.ones(ns, np.bool_)
    width = starts[1] - starts[0]
    nz = width * (width + 1) // 2 + width * (count[starts[1] - 1] - 1)
    for s in range(ns - 1):
        w1 = starts[s + 2] - starts[s + 1]
        r1 = count[starts[s + 2] - 1] - 1
        nz1 = w1 * (w1 + 1) // 2 + w1 * r1
        merged = False
        if sparent[s] == s + 1 and not fixed[s + 1]:
            w = width + w1
            stored = w * (w + 1) // 2 + w * r1
            zeros = 1.0 - (nz + nz1) / stored
            for k in range(relax.shape[0]):
                if w <= relax[k, 0]:
                    merged = zeros <= relax[k, 1]
                    break
        if merged:
            keep[s + 1] = False
            width += w1
            nz += nz1
        else:
            width, nz = w1, nz1
    return keep


@numba.njit(cache=True, nogil=True, inline="always")
def _take_row(i, c1, s, mark, R, k, end):  # pragma: no cover - compiled
    """Append row ``i`` to supernode ``s``'s rows at ``R[k]`` if it lies below the block and is new; -1 past ``end``."""
    if i >= c1 and mark[i] != s:
        if k >= end:
            return -1
        mark[i] = s
        R[k] = i
        k += 1
    return k


@numba.njit(cache=True, nogil=True)
def _rows_below(starts, sparent, Sp, Si, rstart, R):  # pragma: no cover - compiled
    """``R`` of every supernode: rows of ``A`` below its columns and its children's ``R``, beyond its last column.

    Returns False when a count disagrees with the column counts behind ``rstart``.
    """
    ns = starts.shape[0] - 1
    n = Sp.shape[0] - 1
    mark = np.full(n, -1, np.int64)
    head = np.full(ns, -1, np.int64)
    nxt = np.full(ns, -1, np.int64)
    for s in range(ns - 1, -1, -1):
        p = sparent[s]
        if p >= 0:
            nxt[s] = head[p]
            head[p] = s
    for s in range(ns):
        c0, c1 = starts[s], starts[s + 1]
        k = rstart[s]
        for c in range(c0, c1):
            for p in range(Sp[c], Sp[c + 1]):
                k = _take_row(Si[p], c1, s, mark, R, k, rstart[s + 1])
                if k < 0:
                    return False
        t = head[s]
        while t != -1:
            for q in range(rstart[t], rstart[t + 1]):
                k = _take_row(R[q], c1, s, mark, R, k, rstart[s + 1])
                if k < 0:
                    return False
            t = nxt[t]
        if k != rstart[s + 1]:
            return False
        R[rstart[s]:k].sort()
    return True


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
    perm = np.asarray(perm, np.int64)
    Sp, Si = _pattern(sp.csc_matrix(A[perm][:, perm]))
    post = _postorder(_etree(Sp, Si))
    perm = perm[post]
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
    if not _rows_below(starts, sparent, Sp, Si, rstart, R):
        raise Unsuitable("the supernodes' row sets disagree with the column counts")
    split = np.searchsorted(starts, [m1, m2]).astype(np.int64) if 0 < m1 < m2 else np.zeros(2, np.int64)
    return Symbolic(perm, starts, sparent, rstart, R, split)


# ---------------------------------------------------------------------------------------------- numeric


@numba.njit(cache=True, nogil=True, inline="always")
def _trsm(single, side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb):  # pragma: no cover - compiled
    if single:
        _strsm(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb)
    else:
        _dtrsm(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb)


@numba.njit(cache=True, nogil=True, inline="always")
def _gemm(single, ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc):  # pragma: no cover - compiled
    if single:
        _sgemm(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)
    else:
        _dgemm(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)


@numba.njit(cache=True, nogil=True)
def _partial_lu(F, w, panel, chars, ints, scal):  # pragma: no cover - compiled
    """LU of the first ``w`` pivots of the dense (m, m) row-major front ``F`` in place; False on a bad pivot.

    On return ``F[:w, :w]`` holds ``L11`` (unit, strictly lower) and ``U11``,
    ``F[w:, :w]`` holds ``L21``, ``F[:w, w:]`` holds ``U12`` and ``F[w:, w:]`` the
    Schur complement. BLAS sees the row-major front as its column-major
    transpose, so every call below is written for the transposed blocks.
    ``F`` is float32 or float64 (``scal``, the constants -1 and 1, of the same type).
    """
    m = F.shape[0]
    base = F.ctypes.data
    sz = F.itemsize
    single = sz == 4
    # chars: N, L, U, R; ints: the leading dimension m, then the block's sizes
    ld = ints[0:1].ctypes.data
    minus, one = scal[0:1].ctypes.data, scal[1:2].ctypes.data
    cN, cL, cU, cR = chars[0:1].ctypes.data, chars[1:2].ctypes.data, chars[2:3].ctypes.data, chars[3:4].ctypes.data
    for k0 in range(0, w, panel):
        k1 = min(k0 + panel, w)
        b = k1 - k0
        for k in range(k0, k1):  # the diagonal block, unblocked
            piv = F[k, k]
            if piv == 0.0 or not np.isfinite(piv):
                return False
            inv = 1.0 / piv
            for i in range(k + 1, k1):
                F[i, k] *= inv
                lik = F[i, k]
                if lik != 0.0:
                    for j in range(k + 1, k1):
                        F[i, j] -= lik * F[k, j]
        rest = m - k1
        if rest == 0:
            continue
        ints[1] = b
        ints[2] = rest
        nb = ints[1:2].ctypes.data
        nr = ints[2:3].ctypes.data
        diag = base + sz * (k0 * m + k0)
        # L21 U11 = F21: in BLAS's view U11^T X = F21^T, U11^T the lower triangle of the block
        _trsm(single, cL, cL, cN, cN, nb, nr, one, diag, ld, base + sz * (k1 * m + k0), ld)
        # L11 U12 = F12: in BLAS's view X L11^T = F12^T, L11^T the strict upper triangle, unit
        _trsm(single, cR, cU, cN, cU, nr, nb, one, diag, ld, base + sz * (k0 * m + k1), ld)
        # F22 -= L21 U12: in BLAS's view F22^T -= U12^T L21^T
        _gemm(single, cN, cN, nr, nr, nb, minus, base + sz * (k0 * m + k1), ld, base + sz * (k1 * m + k0), ld,
              one, base + sz * (k1 * m + k1), ld)
    return True


@numba.njit(cache=True, nogil=True)
def _stack_peak(s_lo, s_hi, rstart, nchild, sizes0):  # pragma: no cover - compiled
    """Most float64 values the update-matrix stack holds while ``s_lo..s_hi-1`` are factored.

    ``sizes0``: the sizes of the update matrices on the stack before the first.
    """
    sizes = np.empty(sizes0.shape[0] + s_hi - s_lo, np.int64)
    top = sizes0.shape[0]
    sizes[:top] = sizes0
    used = sizes0.sum()
    peak = used
    for s in range(s_lo, s_hi):
        for _ in range(nchild[s]):
            top -= 1
            used -= sizes[top]
        r = rstart[s + 1] - rstart[s]
        if r:
            sizes[top] = r * r
            top += 1
            used += r * r
            if used > peak:
                peak = used
    return peak


@numba.njit(cache=True, nogil=True)
def _factor_range(s_lo, s_hi, starts, rstart, R, nchild, Ap, Ai, Ax, Tp, Ti, Tx, bstart, dstart,
                  LB, UB, LD, UD, udinv, buf, ent_s, ent_off, top, Fbuf, panel):  # pragma: no cover - compiled
    """Factor supernodes ``s_lo..s_hi-1`` (a postordered range); returns (first bad supernode or -1, stack top).

    The update matrices waiting for their parent are a stack in ``buf``: entry
    ``q < top`` is supernode ``ent_s[q]``'s, ``r x r`` values from ``ent_off[q]``,
    its rows ``R`` of that supernode. A supernode pops its children's (the last
    ones pushed, postorder) and pushes its own. ``Fbuf`` holds the largest front.
    """
    n = starts[-1]
    loc = np.full(n, -1, np.int64)
    chars = np.array([ord("N"), ord("L"), ord("U"), ord("R")], np.uint8)
    ints = np.zeros(4, np.int32)
    scal = np.array([-1.0, 1.0], Fbuf.dtype)
    for s in range(s_lo, s_hi):
        c0, c1 = starts[s], starts[s + 1]
        w = c1 - c0
        r0 = rstart[s]
        r = rstart[s + 1] - r0
        m = w + r
        for a in range(w):
            loc[c0 + a] = a
        for i in range(r):
            loc[R[r0 + i]] = w + i
        F = Fbuf[:m * m].reshape((m, m))
        F[:, :] = 0.0
        for c in range(c0, c1):  # columns of A: the diagonal block and L's part
            a = c - c0
            for p in range(Ap[c], Ap[c + 1]):
                i = Ai[p]
                if i >= c0:
                    F[loc[i], a] += Ax[p]
        for c in range(c0, c1):  # rows of A beyond the block: U's part
            a = c - c0
            for p in range(Tp[c], Tp[c + 1]):
                j = Ti[p]
                if j >= c1:
                    F[a, loc[j]] += Tx[p]
        for _ in range(nchild[s]):  # extend-add of the children's update matrices
            top -= 1
            t = ent_s[top]
            off = ent_off[top]
            t0 = rstart[t]
            k = rstart[t + 1] - t0
            for x in range(k):
                lx = loc[R[t0 + x]]
                row = off + x * k
                for y in range(k):
                    F[lx, loc[R[t0 + y]]] += buf[row + y]
        ints[0] = m
        if not _partial_lu(F, w, panel, chars, ints, scal):
            return s, top
        d0 = dstart[s]
        for a in range(w):
            udinv[c0 + a] = 1.0 / F[a, a]
            for e in range(w):
                if e < a:
                    LD[d0 + a * w + e] = F[a, e]
                elif e > a:
                    UD[d0 + a * w + e] = F[a, e]
        b0 = bstart[s]
        for a in range(w):
            for i in range(r):
                LB[b0 + a * r + i] = F[w + i, a]
                UB[b0 + a * r + i] = F[a, w + i]
        if r:
            off = ent_off[top - 1] + (rstart[ent_s[top - 1] + 1] - rstart[ent_s[top - 1]]) ** 2 if top else 0
            for x in range(r):
                for y in range(r):
                    buf[off + x * r + y] = F[w + x, w + y]
            ent_s[top] = s
            ent_off[top] = off
            top += 1
        for a in range(w):
            loc[c0 + a] = -1
        for i in range(r):
            loc[R[r0 + i]] = -1
    return -1, top


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
        self.buf = np.empty(max(1, int(_stack_peak(s_lo, s_hi, rstart, nchild, sizes0))), dtype)
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
        prev = mkl_local_threads(_MKL, blas_threads) if _MKL is not None else 0
        try:
            got, st.top = _factor_range(lo, hi, *args, st.buf, st.ent_s, st.ent_off, st.top,
                                        np.empty(int(fronts[lo:hi].max(initial=1)), dt), PANEL)
        finally:
            if _MKL is not None:
                mkl_local_threads(_MKL, prev)
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
