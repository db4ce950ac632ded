"""MKL PARDISO called directly: LU, Cholesky and LDL^T factors in double or single precision.

The call goes through the compiled core (``tetmorph_core.Mkl``, which opens MKL's
runtime with ``dlopen`` and calls ``pardiso`` without the GIL); MKL is optional and
never linked.

One object owns one PARDISO handle: ``phase 12`` (ordering, symbolic and
numeric factorization) in the constructor, ``phase 33`` (back-substitution)
in :meth:`PardisoFactor.solve`, ``phase -1`` on release. Compared with going
through pypardiso, which this module replaces for tetmorph's systems:

* the index arrays are converted once, not on every solve (pypardiso builds
  ``indptr + 1`` and ``indices + 1`` and compares the whole matrix with its
  stored copy on every call: several milliseconds at 1M elements);
* single precision (``iparm(28) = 1``) is available: the factor's values are
  float32, so a back-substitution reads half the bytes. pypardiso refuses
  float32 matrices;
* several right-hand sides are solved in one call (``nrhs``).

Settings (MKL's 1-based iparm numbers): nested dissection (``iparm(2) = 2``);
the reproducible mode, whose factor has the same bits on any number of threads
(``iparm(34) = 4``); no iterative refinement (``iparm(8) = 0``; tetmorph solves
in residual form and refines where it measures that it matters); pivot
perturbation 1e-13 (``iparm(10) = 13``); scaling and weighted matching for
non-symmetric and indefinite matrices (``iparm(11) = iparm(13) = 1``); the
factor's size reported (``iparm(18) = -1``); zero-based indices
(``iparm(35) = 1``). Indefinite (KKT) systems keep two refinement steps and
Bunch-Kaufman pivoting (``iparm(8) = 2``, ``iparm(21) = 1``).
"""

from __future__ import annotations

import functools
import glob
import os
import sys
import threading

import numpy as np
import scipy.sparse as sp
import tetmorph_core

from ..environment import START
from ..errors import FactorizationError
from .layout import c_copy, fortran_copy
from .threads import WIDE_COLUMNS, solve_threads

__all__ = ["PardisoFactor", "mkl_runtime", "loaded_mkl", "nested_dissection"]

#: iparm(2), the fill-reducing ordering: METIS's nested dissection on one thread. (The OpenMP one,
#: 3, rules out the reproducible mode below: MKL's manual.)
ORDERING = 2
#: iparm(34): the factorization's reproducible mode, its work split as for this many threads
#: whatever number runs it. Without it, the numeric factorization's rounding follows MKL's thread
#: count, so that a process on one thread (a Ray worker, ``--threads 1``) wrote other bits than
#: one on two. ``benchmarks/measure_choices.py --only nd-threads`` measures its cost.
REPRODUCIBLE_THREADS = 4
#: iparm(2) of :func:`nested_dissection`, the ordering alone (the multifrontal LU's): the OpenMP
#: nested dissection, which gave the one-thread ordering's permutation on every system measured,
#: on one thread and two (``tests/solver/linalg/test_pardiso.py``), and sooner
#: (``benchmarks/measure_choices.py --only nd-threads``).
ORDERING_ONLY = 3

_LIB: tetmorph_core.Mkl | None = None
_LOCK = threading.Lock()


@functools.cache
def mkl_runtime() -> str | None:
    """Path of MKL's single dynamic library (``libmkl_rt``), or None when MKL is not installed (looked up once)."""
    env = START.mkl_rt
    if env and os.path.exists(env):
        return env
    # pip's mkl wheel puts it in <prefix>/lib; a recursive search of the prefix is the fallback
    found = sorted(glob.glob(f"{sys.prefix}/lib/libmkl_rt.so*"), key=len) or \
        sorted(glob.glob(f"{sys.prefix}/[Ll]ib*/**/*mkl_rt*", recursive=True), key=len)
    return found[0] if found else None


def loaded_mkl() -> tetmorph_core.Mkl | None:
    """MKL's library when this process has loaded it already (PARDISO, the fronts' BLAS), else None.

    Never loads it: ``dlopen`` with ``RTLD_NOLOAD`` only finds a library already in the process.
    """
    path = mkl_runtime()
    if path is None:
        return None
    try:
        return tetmorph_core.Mkl(path, load=False)
    except OSError:
        return None


def _library() -> tetmorph_core.Mkl:
    """MKL's runtime, loaded on first use (``unknown_backend`` when it is not installed or does not load)."""
    global _LIB
    with _LOCK:
        if _LIB is None:
            path = mkl_runtime()
            if path is None:
                raise FactorizationError("MKL PARDISO is not installed (no libmkl_rt found)", code="unknown_backend")
            try:
                _LIB = tetmorph_core.Mkl(path)
            except OSError as e:
                raise FactorizationError(f"MKL PARDISO could not be loaded: {e}", code="unknown_backend") from e
        return _LIB


#: PARDISO's error codes (MKL reference).
_ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
           -4: "zero pivot, numerical factorization or iterative refinement problem", -5: "unclassified internal error",
           -6: "reordering failed", -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
           -9: "not enough memory for out-of-core", -10: "error opening out-of-core files",
           -11: "read/write error with out-of-core files", -12: "wrong pardiso_64 call", -13: "interrupted",
           -15: "internal error"}


def check_index_range(nnz: int, what: str) -> None:
    """Refuse a matrix whose nonzeros do not fit PARDISO's 32-bit indices (``too_large``)."""
    if nnz >= 2**31:
        raise FactorizationError(f"{what}: {nnz} nonzeros exceed PARDISO's 32-bit indices", code="too_large",
                                 nonzeros=nnz)


class PardisoFactor:
    """A PARDISO factorization of one sparse matrix, owned by this object.

    Parameters
    ----------
    M : (n, n) sparse matrix
    what : str
        Name of the system, for error messages.
    mtype : {11, 2, -2}
        Real non-symmetric (LU), symmetric positive definite (Cholesky), or
        symmetric indefinite (LDL^T). For 2 and -2 only the upper triangle is used.
    single : bool
        Factor and solve in single precision (float32 values, right-hand sides
        and solutions; the caller converts where it needs to).

    Raises
    ------
    FactorizationError
        ``singular_system`` when PARDISO reports a zero pivot or perturbs one
        (non-indefinite systems), or another PARDISO error.

    Notes
    -----
    ``solve`` holds a per-object lock: PARDISO's handle carries work space, so
    concurrent back-substitutions on one factor are serialized.
    """

    name = "pardiso"

    def __init__(self, M: sp.spmatrix, what: str, mtype: int = 11, single: bool = False) -> None:
        self._lib = _library()
        self.mtype = mtype
        self.single = single
        self.dtype = np.float32 if single else np.float64
        n = M.shape[0]
        if mtype in (2, -2):
            M = sp.coo_matrix(M)
            if mtype == -2:  # PARDISO needs every diagonal entry stored, zero or not
                i = np.arange(n)
                M = sp.coo_matrix((np.r_[M.data, np.zeros(n)], (np.r_[M.row, i], np.r_[M.col, i])), shape=M.shape)
            M = sp.triu(M, format="csr")
        A = sp.csr_matrix(M)
        A.sum_duplicates()
        A.sort_indices()
        check_index_range(int(A.nnz), what)
        self._a = np.ascontiguousarray(A.data, dtype=self.dtype)
        self._ia = np.ascontiguousarray(A.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(A.indices, dtype=np.int32)
        self.shape = (n, n)
        self._pt = np.zeros(64, np.int64)
        self._iparm = np.zeros(64, np.int32)
        for k, v in {1: 1, 2: ORDERING, 8: 0, 10: 13, 11: 1, 13: 1, 18: -1, 34: REPRODUCIBLE_THREADS,
                     35: 1}.items():
            self._iparm[k - 1] = v
        if mtype == -2:
            self._iparm[7], self._iparm[20] = 2, 1
        elif mtype == 2:  # positive definite: no pivoting, scaling or matching
            self._iparm[9], self._iparm[10], self._iparm[12] = 0, 0, 0
        if single:
            self._iparm[27] = 1
        self._perm = np.zeros(n, np.int32)
        self._lock = threading.Lock()
        self._stacked = False  # has made a stacked solve: keep its thread count (solver.linalg.threads)
        self._alive = False
        err = self._call(12, np.zeros((n, 1), self.dtype, order="F"), np.zeros((n, 1), self.dtype, order="F"))
        self._alive = True
        if err:
            self.release()
            kind = "singular_system" if err in (-4, -7) else "factorization_failed"
            raise FactorizationError(f"{what}: PARDISO failed on the {n}x{n} system ({_ERRORS.get(err, err)})",
                                     code=kind)
        perturbed = int(self._iparm[13])
        if perturbed > 0 and mtype != -2:
            self.release()
            raise FactorizationError(f"{what}: the {n}x{n} system is singular ({perturbed} zero pivots)",
                                     code="singular_system")
        self.nnz = abs(int(self._iparm[17]))
        self.nbytes = self.nnz * (4 if single else 8) + self._a.nbytes + self._ia.nbytes + self._ja.nbytes

    def _call(self, phase: int, b: np.ndarray, x: np.ndarray) -> int:
        return self._lib.pardiso(self._pt, self.mtype, phase, self.shape[0], self._a, self._ia, self._ja, self._perm,
                                 b.shape[1], self._iparm, b, x)

    def solve(self, b: np.ndarray, stacked: bool = False) -> np.ndarray:
        """Solve ``A x = b`` for ``b`` of shape (n,) or (n, k).

        Parameters
        ----------
        b : (n,) or (n, k) array
        stacked : bool
            Schedule as a stacked solve whatever the width (a DOE's basis and
            left-over columns, which may be few: :mod:`solver.linalg.threads`).

        Returns
        -------
        x : array of ``b``'s shape, float32 for a single-precision factor, else float64
            (callers keep a float32 solution as it is: its values widen exactly, and a
            stacked solve's residual then gathers half the bytes)
        """
        shape = np.shape(b)
        B = fortran_copy(np.reshape(b, (shape[0], -1)), self.dtype)
        X = np.empty_like(B, order="F")
        with self._lock:
            self._stacked = self._stacked or stacked
            n_threads = solve_threads(B.shape[1], self._stacked)  # see solver.linalg.threads
            self._stacked = self._stacked or B.shape[1] > WIDE_COLUMNS  # a scheduling hint, not a result
            prev = self._lib.set_local_threads(n_threads)
            try:
                err = self._call(33, B, X)
            finally:
                self._lib.set_local_threads(prev)
        if err:
            raise FactorizationError(f"PARDISO back-substitution failed ({_ERRORS.get(err, err)})",
                                     code="factorization_failed")
        return c_copy(X, self.dtype).reshape(shape)

    def release(self) -> None:
        """Free PARDISO's memory for this factor (also done when the object is collected)."""
        if self._alive:
            dummy = np.zeros((1, 1), self.dtype, order="F")
            self._call(-1, dummy, dummy)
            self._alive = False

    def __del__(self) -> None:
        try:
            self.release()
        except Exception:  # interpreter shutdown
            pass


def nested_dissection(A: sp.spmatrix) -> np.ndarray:
    """PARDISO's fill-reducing METIS ordering of ``A``'s symmetrized pattern (its phase 11 only).

    The compiled call releases the GIL, so the ordering runs beside other
    Python threads (unlike CHOLMOD's analysis through scikit-sparse).

    Parameters
    ----------
    A : (n, n) sparse matrix

    Returns
    -------
    perm : (n,) int64 array
        Row ``i`` of the ordered matrix is row ``perm[i]`` of ``A``.

    Raises
    ------
    FactorizationError
        PARDISO is missing or its analysis failed.
    """
    lib = _library()
    M = sp.csr_matrix(A, dtype=np.float64)
    M.sum_duplicates()
    M.sort_indices()
    n = M.shape[0]
    check_index_range(int(M.nnz), "ordering")
    a = np.ascontiguousarray(M.data)
    ia = np.ascontiguousarray(M.indptr, dtype=np.int32)
    ja = np.ascontiguousarray(M.indices, dtype=np.int32)
    pt = np.zeros(64, np.int64)
    iparm = np.zeros(64, np.int32)
    # iparm(5) = 2: return the ordering
    for k, v in {1: 1, 2: ORDERING_ONLY, 5: 2, 8: 0, 10: 13, 11: 0, 13: 0, 35: 1}.items():
        iparm[k - 1] = v
    perm = np.zeros(n, np.int32)
    dummy = np.zeros(1)

    def call(phase: int) -> int:
        return lib.pardiso(pt, 11, phase, n, a, ia, ja, perm, 1, iparm, dummy, dummy)

    err = call(11)
    call(-1)
    if err:
        raise FactorizationError(f"PARDISO's ordering of the {n}x{n} system failed ({_ERRORS.get(err, err)})",
                                 code="factorization_failed")
    return perm.astype(np.int64)
