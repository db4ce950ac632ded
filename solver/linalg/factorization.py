"""Sparse direct factorizations: the one place that picks the backend.

Backends, in order of preference:

``cholmod``
    SuiteSparse CHOLMOD through scikit-sparse (supernodal Cholesky, BLAS-3).
    Installed by ``make`` from Debian's ``libsuitesparse-dev`` with OpenBLAS.
``pardiso``
    Intel MKL PARDISO, called directly (:mod:`solver.linalg.pardiso`; MKL from pip). Used for the square,
    non-symmetric mean-value-coordinate system (LU with a symmetric METIS
    ordering, far faster than SuperLU there: measure_choices ``small-lu``), and for symmetric systems too when
    CHOLMOD is missing.
``supernodal``
    Systems solved on every update, back-substituted by tetmorph's own
    two-thread dense supernode sweeps (:mod:`solver.linalg.supernodal`),
    which cost less than PARDISO's and CHOLMOD's solves: the square
    mean-value system above ``LU_SMALL`` unknowns (tetmorph's multifrontal LU
    without pivoting on PARDISO's nested-dissection ordering,
    :mod:`solver.linalg.multifrontal`) and the boundary position system up to
    ``SUPERNODAL_MAX`` (CHOLMOD's factor exported). Systems that need pivoting
    stay with PARDISO.
``scipy``
    SuperLU through :func:`scipy.sparse.linalg.splu`. Always available but one
    to two orders of magnitude slower on large meshes.

Falling back from CHOLMOD emits a :class:`PerformanceWarning` once.
``SolveOptions(backend=...)`` (:mod:`solver.options`; ``TETMORPH_SOLVER`` at start-up) forces the symmetric backend
(``scipy`` also forces SuperLU for the non-symmetric one).

Process-wide counters (:data:`STATS`: ``"factorizations"``, ``"solves"`` of CHOLMOD and SuperLU) are
kept for tests and diagnostics only; no REPORT reads them (each precompute
object counts its own factorizations). Factors are built once and never
mutated. CHOLMOD and PARDISO keep work space inside the factor object, so
their ``solve`` holds a per-factor lock: concurrent solves on one factor are
serialized rather than corrupted.
"""

from __future__ import annotations

import threading
import warnings
from collections import Counter
from typing import Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import FactorizationError
from ..options import current as current_options
from .multifrontal import lu_multifrontal
from .ordering import symmetric_ordering
from .pardiso import PardisoFactor, mkl_runtime
from .supernodal import Unsuitable, cholmod_supernodal
from .threads import openblas

__all__ = ["STATS", "Factor", "PerformanceWarning", "backend", "lu_backend", "cholesky", "lu", "ldl"]

#: Counters of factorizations (``"factorizations"``) and solves (``"solves"``), for tests.
STATS: Counter[str] = Counter()
_STATS_LOCK = threading.Lock()


def _count(key: str) -> None:
    with _STATS_LOCK:
        STATS[key] += 1


class PerformanceWarning(UserWarning):
    """Emitted once when tetmorph runs on the slow pip-only backend."""


class Factor(Protocol):
    """A factorization of a square sparse matrix; ``solve`` only back-substitutes."""

    shape: tuple[int, int]
    nbytes: int
    name: str

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b`` for ``b`` of shape (n,) or (n, k)."""
        ...


#: The backend each ``SolveOptions.backend`` resolved to (``auto``: the first installed).
_BACKEND: dict[str, str] = {}
BACKENDS = ("cholmod", "pardiso", "scipy")


def _importable(module: str) -> bool:
    if module == "mkl":
        return mkl_runtime() is not None
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def backend() -> str:
    """Name of the backend for symmetric positive definite systems, under the options in effect.

    Returns
    -------
    str
        ``"cholmod"``, ``"pardiso"`` or ``"scipy"``: the one
        :func:`solver.options.current` names, or for ``auto`` the first
        installed of those (a warning when it is not CHOLMOD).

    Raises
    ------
    FactorizationError
        ``unknown_backend`` when the options name an unknown or unavailable backend.
    """
    wanted = current_options().backend
    if wanted in _BACKEND:
        return _BACKEND[wanted]
    modules = {"cholmod": "sksparse.cholmod", "pardiso": "mkl", "scipy": "scipy"}
    if wanted != "auto":
        if wanted not in BACKENDS:
            raise FactorizationError(f"solver backend {wanted!r} (TETMORPH_SOLVER or SolveOptions) is not a "
                                     f"backend; use one of {list(BACKENDS)}", code="unknown_backend")
        if not _importable(modules[wanted]):
            raise FactorizationError(f"solver backend {wanted!r} but {modules[wanted]} is not installed",
                                     code="unknown_backend")
        _BACKEND[wanted] = wanted
    else:
        found = next(b for b in BACKENDS if _importable(modules[b]))
        if found != "cholmod":
            warnings.warn(
                f"CHOLMOD (scikit-sparse) is not installed: tetmorph uses {found} for "
                "symmetric systems, which is slower on large meshes. Run 'make install' as "
                "root on Debian/Ubuntu to get CHOLMOD.", PerformanceWarning, stacklevel=2)
        _BACKEND[wanted] = found
    return _BACKEND[wanted]


_LU_BACKEND: dict[str, str] = {}
#: Square systems up to this size use SuperLU even when PARDISO is there: on small
#: systems PARDISO's solve costs more, while SuperLU's factorization grows much faster
#: with size than the others'. Measured on interior mean-value systems:
#: ``benchmarks/measure_choices.py --only small-lu``.
LU_SMALL = 5_000


#: Symmetric systems up to this size are back-substituted by tetmorph's own dense supernode
#: sweeps (:mod:`solver.linalg.supernodal`, CHOLMOD's ``L`` exported); larger ones keep CHOLMOD's
#: solve, whose cost is near the factor's memory traffic there. Square mean-value systems above
#: ``LU_SMALL`` get the sweeps at every size, factored by :mod:`solver.linalg.multifrontal`.
#: ``benchmarks/measure_choices.py --only supernodal`` measures both sides.
#: ``SolveOptions(sweeps=False)`` (or ``TETMORPH_SUPERNODAL=0``) keeps PARDISO and CHOLMOD at every size.
SUPERNODAL_MAX = 40_000


def _sweeps_on() -> bool:
    """Whether the supernodal sweeps are on (:attr:`solver.options.SolveOptions.sweeps`)."""
    return current_options().sweeps


def _supernodal(n: int) -> bool:
    """Whether an ``n``-unknown system gets the supernodal sweeps (``SUPERNODAL_MAX``, the options' ``sweeps``)."""
    return LU_SMALL < n <= SUPERNODAL_MAX and _sweeps_on()


def lu_backend() -> str:
    """Name of the backend for square non-symmetric systems (``"pardiso"`` or ``"scipy"``)."""
    b = backend()
    if b not in _LU_BACKEND:
        _LU_BACKEND[b] = "pardiso" if b != "scipy" and _importable("mkl") else "scipy"
    return _LU_BACKEND[b]


def _check_finite(M: sp.spmatrix, what: str) -> None:
    if not np.all(np.isfinite(M.data)):
        raise FactorizationError(f"{what}: the matrix has non-finite entries", code="non_finite_matrix")


def _prepared(M: sp.spmatrix, what: str) -> sp.csc_matrix:
    """``M`` as CSC, checked finite, and counted in :data:`STATS` as one factorization."""
    M = sp.csc_matrix(M)
    _check_finite(M, what)
    _count("factorizations")
    return M


_BLAS_QUIETED = False


def _quiet_system_blas() -> None:
    """One thread for the system OpenBLAS that CHOLMOD links (Debian's openblas-pthread).

    OpenBLAS threads busy-wait after every call. On two cores they take cycles
    from PARDISO's threads and the compiled kernels' in the next step of the update, while
    CHOLMOD's small dense blocks gain little from a second thread (compare
    ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_solver.py --case
    bracket:0.95:split --updates 60`` with the default). Only libraries outside the
    Python prefix are touched, so numpy's and scipy's own BLAS keep their
    threads.
    """
    global _BLAS_QUIETED
    if _BLAS_QUIETED:
        return
    _BLAS_QUIETED = True
    for lib in openblas(own=False):  # its own C function: threadpoolctl's would ignore any thread but its first
        lib.set_num_threads(1)


class _CholmodFactor:
    """CHOLMOD's supernodal factor on :func:`~solver.linalg.ordering.symmetric_ordering`'s permutation.

    ``_f`` has scikit-sparse's interface (``L()``, ``P()``, called to solve) for
    the matrix as given: ``L L^T = M[P][:, P]``.
    """

    name = "cholmod"

    def __init__(self, M: sp.csc_matrix, what: str) -> None:
        from sksparse.cholmod import CholmodNotPositiveDefiniteError
        from sksparse.cholmod import cholesky as chol

        _quiet_system_blas()
        perm = symmetric_ordering(M)
        try:
            if perm is None:
                self._f: _Ordered | object = chol(M, mode="supernodal", ordering_method="amd")
            else:  # CHOLMOD's natural ordering keeps the order given
                f = chol(sp.csc_matrix(M[perm][:, perm]), mode="supernodal", ordering_method="natural")
                self._f = _Ordered(f, perm)
        except CholmodNotPositiveDefiniteError as e:
            raise FactorizationError(
                f"{what}: the {M.shape[0]}x{M.shape[0]} system is singular or not positive "
                f"definite ({e})",
                code="singular_system",
            ) from e
        self._lock = threading.Lock()
        L = self._f.L()  # type: ignore[attr-defined]
        self.nbytes = int(L.data.nbytes + L.indices.nbytes + L.indptr.nbytes)
        self.shape = M.shape

    def solve(self, b: np.ndarray) -> np.ndarray:
        _count("solves")
        with self._lock:
            return self._f(b)  # type: ignore[operator]


class _Ordered:
    """A CHOLMOD factor of ``M[perm][:, perm]``, seen as a factor of ``M`` (scikit-sparse's interface)."""

    __slots__ = ("_f", "_perm")

    def __init__(self, f: object, perm: np.ndarray) -> None:
        self._f = f
        self._perm = perm

    def L(self) -> sp.csc_matrix:
        """The lower factor: ``L L^T = M[P()][:, P()]``."""
        return self._f.L()  # type: ignore[attr-defined]

    def P(self) -> np.ndarray:
        """The whole permutation: the ordering, then CHOLMOD's post-order of it."""
        return self._perm[self._f.P()]  # type: ignore[attr-defined]

    def __call__(self, b: np.ndarray) -> np.ndarray:
        """``M^{-1} b`` for ``b`` of shape (n,) or (n, k)."""
        y = self._f(b[self._perm])  # type: ignore[operator]
        x = np.empty_like(y)
        x[self._perm] = y
        return x


class _SuperLUFactor:
    name = "scipy"

    def __init__(self, M: sp.csc_matrix, what: str, symmetric: bool) -> None:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", spla.MatrixRankWarning)
                self._f = spla.splu(
                    M,
                    permc_spec="MMD_AT_PLUS_A" if symmetric else "COLAMD",
                    options={"SymmetricMode": symmetric},
                )
        except (RuntimeError, spla.MatrixRankWarning) as e:
            raise FactorizationError(
                f"{what}: the {M.shape[0]}x{M.shape[0]} system is singular ({e})",
                code="singular_system",
            ) from e
        self.nbytes = int(self._f.L.nnz + self._f.U.nnz) * 12
        self.shape = M.shape

    def solve(self, b: np.ndarray) -> np.ndarray:
        _count("solves")
        return self._f.solve(np.asarray(b, dtype=np.float64))


def cholesky(M: sp.spmatrix, what: str = "system", sweeps: bool = False) -> Factor:
    """Factor a symmetric positive definite sparse matrix.

    Parameters
    ----------
    M : (n, n) sparse matrix
        Symmetric positive definite.
    what : str
        Name of the system, used in error messages.
    sweeps : bool
        Back-substitute with the supernodal sweeps (CHOLMOD's ``L`` exported; sizes
        above ``LU_SMALL`` up to ``SUPERNODAL_MAX``): for systems solved on every
        update. The export costs set-up time, so systems solved only at set-up
        keep CHOLMOD's own solve.

    Returns
    -------
    Factor
        Object whose ``solve(b)`` back-substitutes for ``b`` of shape (n,) or (n, k).

    Raises
    ------
    FactorizationError
        If ``M`` is singular, indefinite or has non-finite entries.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> f = cholesky(sp.diags([2.0, 4.0]))
    >>> np.round(f.solve(np.array([2.0, 2.0])), 12).tolist()
    [1.0, 0.5]
    """
    M = _prepared(M, what)
    b = backend()
    if b == "cholmod":
        f = _CholmodFactor(M, what)
        if sweeps and _supernodal(M.shape[0]):
            try:
                return cholmod_supernodal(f._f, M)
            except Unsuitable:  # the probe missed: CHOLMOD's own solve
                pass
        return f
    if b == "pardiso":
        return PardisoFactor(M, what, mtype=2)
    return _SuperLUFactor(M, what, symmetric=True)


def lu(A: sp.spmatrix, what: str = "system", single: bool = False) -> Factor:
    """Factor a square, possibly non-symmetric, non-singular sparse matrix.

    Parameters
    ----------
    A : (n, n) sparse matrix
    what : str
        Name of the system, used in error messages.
    single : bool
        Factor in single precision where the backend can (above ``LU_SMALL``
        unknowns: the multifrontal factor and its supernodal sweeps, or MKL
        PARDISO where a pivot is needed): half the bytes per back-substitution; the solution carries
        single-precision rounding (the caller refines or states the accuracy).

    Returns
    -------
    Factor

    Raises
    ------
    FactorizationError
        If ``A`` is singular or has non-finite entries.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> f = lu(sp.csr_matrix([[2.0, 1.0], [0.0, 1.0]]))
    >>> np.round(f.solve(np.array([3.0, 1.0])), 12).tolist()
    [1.0, 1.0]
    """
    A = _prepared(A, what)
    if lu_backend() == "pardiso" and A.shape[0] > LU_SMALL:
        if _sweeps_on():
            try:
                return lu_multifrontal(A, single)
            except Unsuitable:  # needs pivoting: PARDISO pivots
                pass
        return PardisoFactor(A, what, mtype=11, single=single)
    return _SuperLUFactor(A, what, symmetric=False)


def ldl(K: sp.spmatrix, what: str = "system") -> Factor:
    """Factor a symmetric indefinite sparse matrix (e.g. a KKT matrix).

    MKL PARDISO's symmetric indefinite factorization (``mtype=-2``,
    Bunch-Kaufman pivoting within supernodes) where available, else SuperLU.
    Perturbed pivots are tolerated; callers refine with their own residuals.

    Parameters
    ----------
    K : (n, n) sparse matrix
        Symmetric and non-singular.
    what : str
        Name of the system, used in error messages.

    Returns
    -------
    Factor

    Raises
    ------
    FactorizationError
        If ``K`` is singular or has non-finite entries.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> f = ldl(sp.csr_matrix([[1.0, 1.0], [1.0, 0.0]]))
    >>> np.round(f.solve(np.array([3.0, 1.0])), 12).tolist()
    [1.0, 2.0]
    """
    K = _prepared(K, what)
    if lu_backend() == "pardiso":
        return PardisoFactor(K, what, mtype=-2)
    return _SuperLUFactor(K, what, symmetric=True)
