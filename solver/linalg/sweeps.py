"""The supernodal sweeps: ``y <- U^{-1} L^{-1} y`` over the dense blocks of a supernodal factor.

Compiled kernels in ``src/core/sweeps.cpp``, over the layout that
:class:`~solver.linalg.supernodal.SupernodalFactor` builds: per supernode ``s`` of columns
``starts[s]..starts[s+1]-1``, the rows ``R`` below its diagonal block (from ``rstart[s]``),
the off-diagonal blocks ``LB`` and ``UB`` (``L[R, c0:c1]^T`` and ``U[c0:c1, R]``, row-major,
from ``bstart[s]``), the diagonal blocks ``LD`` and ``UD`` (from ``dstart[s]``) and the
inverted diagonals ``ldinv`` and ``udinv``. Forward, ``y[R] -= L[R, c] y[c]`` is four axpys
at a time into a dense buffer scattered once; backward, ``y[c] -= U[c, R] y[R]`` is dot
products over a buffer gathered once. The kernels compute in the factor's precision
(float32 or float64, accumulations included); every index array is int64.

Two shapes of right-hand side: :func:`_sweep3` takes three at a time, ``y`` (3, n), each a
contiguous vector so the inner loops vectorize (with :func:`_gather` and :func:`_scatter` to
lay a block of columns out that way); :func:`_sweep_wide` takes any number, ``y`` (n, k), so
that each factor entry is read once for all of them. Both sweep the two subtrees of a
``split`` on two threads (OpenMP, the calling thread's count of
``tetmorph_core.set_num_threads``).

The kernels allocate their own work arrays and release the GIL: one factor serves concurrent
solves.
"""

from __future__ import annotations

import numpy as np
import tetmorph_core

__all__: list[str] = []


def _sweep3(starts: np.ndarray, rstart: np.ndarray, R: np.ndarray, bstart: np.ndarray, LB: np.ndarray,
            UB: np.ndarray, dstart: np.ndarray, LD: np.ndarray, UD: np.ndarray, ldinv: np.ndarray,
            udinv: np.ndarray, split: np.ndarray, y: np.ndarray) -> None:
    """``y <- U^{-1} L^{-1} y`` in place for three right-hand sides.

    ``split = (s1, s2)``: supernodes ``0..s1-1`` and ``s1..s2-1`` are two disjoint
    subtrees of the elimination tree, swept on two threads (forward, their
    updates of the shared top columns summed after; backward, after the top);
    supernodes from ``s2`` on are the top, swept on one thread. ``(0, 0)``: one
    thread sweeps everything.

    Parameters
    ----------
    starts : (s + 1,) int64 array
    rstart : (s + 1,) int64 array
    R : (rstart[-1],) int64 array
    bstart : (s + 1,) int64 array
    LB, UB : (bstart[-1],) float32 or float64 arrays
    dstart : (s + 1,) int64 array
    LD, UD : (dstart[-1],) arrays of ``LB``'s dtype
    ldinv, udinv : (n,) arrays of ``LB``'s dtype
    split : (2,) int64 array
    y : (3, n) C-contiguous array of ``LB``'s dtype
        The right-hand sides, overwritten with the solutions.
    """
    tetmorph_core.sweeps_sweep3(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, split, y)


def _sweep_wide(starts: np.ndarray, rstart: np.ndarray, R: np.ndarray, bstart: np.ndarray, LB: np.ndarray,
                UB: np.ndarray, dstart: np.ndarray, LD: np.ndarray, UD: np.ndarray, ldinv: np.ndarray,
                udinv: np.ndarray, split: np.ndarray, y: np.ndarray) -> None:
    """:func:`_sweep3` for ``y`` of shape (n, k), any k (C-contiguous, of ``LB``'s dtype)."""
    tetmorph_core.sweeps_sweep_wide(starts, rstart, R, bstart, LB, UB, dstart, LD, UD, ldinv, udinv, split, y)


def _gather(B: np.ndarray, perm: np.ndarray, y: np.ndarray) -> None:
    """``y[q // 3, q % 3, i] = B[perm[i], q]``: the permuted right-hand sides, three per sweep.

    Parameters
    ----------
    B : (n, k) float64 array
    perm : (n,) int64 array
    y : (ceil(k / 3), 3, n) C-contiguous float32 or float64 array
        Written (the columns past ``k`` are left as they are).
    """
    tetmorph_core.sweeps_gather(B, perm, y)


def _scatter(y: np.ndarray, perm: np.ndarray, X: np.ndarray) -> None:
    """``X[perm[i], q] = y[q // 3, q % 3, i]``.

    Parameters
    ----------
    y : (ceil(k / 3), 3, n) float32 or float64 array
    perm : (n,) int64 array
    X : (n, k) C-contiguous float64 array
        Written.
    """
    tetmorph_core.sweeps_scatter(y, perm, X)
