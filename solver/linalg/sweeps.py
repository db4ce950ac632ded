"""The supernodal sweeps: ``y <- U^{-1} L^{-1} y`` over the dense blocks of a supernodal factor.

numba kernels over the layout that :class:`~solver.linalg.supernodal.SupernodalFactor`
builds: per supernode ``s`` of columns ``starts[s]..starts[s+1]-1``, the rows ``R`` below
its diagonal block (from ``rstart[s]``), the off-diagonal blocks ``LB`` and ``UB``
(``L[R, c0:c1]^T`` and ``U[c0:c1, R]``, row-major, from ``bstart[s]``), the diagonal blocks
``LD`` and ``UD`` (from ``dstart[s]``) and the inverted diagonals ``ldinv`` and ``udinv``.
Forward, ``y[R] -= L[R, c] y[c]`` is three axpys into a dense buffer scattered once;
backward, ``y[c] -= U[c, R] y[R]`` is dot products over a buffer gathered once.

Two shapes of right-hand side: :func:`_sweep3` takes three at a time, ``y`` (3, n), each a
contiguous vector so the inner loops vectorize (with :func:`_gather` and :func:`_scatter` to
lay a block of columns out that way); :func:`_sweep_wide` takes any number, ``y`` (n, k), so
that each factor entry is read once for all of them. Both sweep the two subtrees of a
``split`` on two threads.

The kernels allocate their own work arrays: one factor serves concurrent solves.
"""

from __future__ import annotations

import numba
import numpy as np


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
