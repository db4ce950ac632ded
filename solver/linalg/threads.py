"""How many threads a per-update back-substitution uses.

An update reads factors and arrays once: it is bound by memory bandwidth,
not by arithmetic, so a second thread gains little, and when the cores are
shared (other sessions, other processes) OpenMP threads that wait for a
descheduled partner at every barrier make it several times slower. Measured
on the 107k-tet bracket while this 2-core machine ran other work: the
interior PARDISO solve 5.0-13.3 ms with one thread against 4.9-12.7 ms with
two, and the whole update 14.6-34.1 ms against 35.5-99.0 ms (a script timing
``Deformer.solve`` under ``threadpool_limits``; ``benchmarks/bench_update.py``
gives the tables). So PARDISO back-substitutions run on ``SOLVE_THREADS``
threads (default 1, ``TETMORPH_SOLVE_THREADS`` to change), set per calling
thread; factorizations keep every thread. The element check is arithmetic,
not bandwidth: it keeps numba's threads (1M tets: 16 ms on one, 8.5 ms on two).
A back-substitution of many right-hand sides at once (a DOE block: more than
``WIDE_COLUMNS`` columns) reads the factor once for all of them and is
arithmetic-bound too, so it runs on every MKL thread. But once a factor has made one
single-threaded back-substitution, PARDISO's stacked solves on it stay slow
whatever the thread count, also after further narrow solves on two threads
(``iparm[24]`` and OpenMP's thread count change nothing). ``python
benchmarks/bench_doe.py --fresh`` shows it: on the 1M bracket, block 16,
65.0 ms per variant on a precompute that has made only stacked solves
against 84.6 on one that made single updates first. So a factor that has
made a stacked solve makes all its later solves on the stacked thread count (:func:`solve_threads`), and the
stacked solves of a ``tetmorph doe`` process or a Ray actor, whose first
solve is stacked, keep both threads through refinement steps and short last
blocks; a service session that has served MOVEs runs its batch as on one
thread. With ``TETMORPH_SOLVE_THREADS=2`` every solve uses two threads, which
suits a machine that runs one job (``TETMORPH_SOLVE_THREADS=2 python
benchmarks/bench_doe.py --sizes 0.44``: DOE block 16 at 0.49 of a single
update, single updates 148.8 ms).
:func:`update_threads` limits numba for callers that want one thread.
"""

from __future__ import annotations

import ctypes
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numba

__all__ = ["SOLVE_THREADS", "STACKED_THREADS", "WIDE_COLUMNS", "solve_threads", "update_threads", "mkl_local_threads",
           "one_blas_thread"]

#: Threads of a per-update solve (MKL and numba, this thread only).
SOLVE_THREADS = max(1, int(os.environ.get("TETMORPH_SOLVE_THREADS", "1") or 1))

#: Right-hand-side columns above which a back-substitution counts as stacked (every thread).
WIDE_COLUMNS = 6


#: Threads of a stacked back-substitution (``TETMORPH_STACKED_THREADS``, default every core).
STACKED_THREADS = max(1, int(os.environ.get("TETMORPH_STACKED_THREADS", "0") or 0)
                      or min(len(os.sched_getaffinity(0)), int(os.environ.get("MKL_NUM_THREADS", "") or 1 << 16)))


def solve_threads(columns: int, stacked_before: bool = False) -> int:
    """MKL threads for a back-substitution of ``columns`` right-hand sides.

    ``stacked_before``: the factor has made a stacked solve; its later solves,
    narrow ones too, keep the stacked thread count, so that a refinement step
    or a short last block does not slow every stacked solve after it (PARDISO
    keeps a factor's earlier thread count, above).
    """
    return STACKED_THREADS if stacked_before or columns > WIDE_COLUMNS else SOLVE_THREADS


def mkl_local_threads(lib: ctypes.CDLL, n: int) -> int:
    """Set MKL's thread count for the calling thread only; returns the previous setting (0: global)."""
    f = getattr(lib, "MKL_Set_Num_Threads_Local", None)
    if f is None:  # pragma: no cover - every MKL since 2017 has it
        return 0
    f.restype = ctypes.c_int
    f.argtypes = [ctypes.c_int]
    return int(f(int(n)))


@contextmanager
def update_threads(n: int | None = None) -> Iterator[None]:
    """Numba kernels of this thread run on ``n`` (default ``SOLVE_THREADS``) threads inside the block."""
    k = min(max(1, n or SOLVE_THREADS), numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]
    prev = numba.get_num_threads()
    numba.set_num_threads(k)
    try:
        yield
    finally:
        numba.set_num_threads(prev)


_OPENBLAS: list | None = None  # numpy's and scipy's own OpenBLAS controllers, found once
_BLAS_LOCK = threading.Lock()
_BLAS_USERS = 0
_BLAS_SAVED: list[int] = []


def _own_openblas() -> list:
    """The OpenBLAS libraries inside this Python's prefix (numpy's and scipy's wheels; not CHOLMOD's system one)."""
    try:
        import sys

        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - a dependency; only speed is at stake
        return []
    prefix = os.path.realpath(sys.prefix)
    return [c for c in ThreadpoolController().lib_controllers
            if c.internal_api == "openblas" and os.path.realpath(c.filepath).startswith(prefix)]


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """NumPy's and SciPy's OpenBLAS on one thread inside the block (process-wide while any thread is inside).

    OpenBLAS's helper threads keep spinning for a while after each call. On two
    cores a spinning helper takes a core from the numba kernel that follows (in a
    DOE block at 1M tets, the residual check after the column basis's small
    products, seen in a throw-away script timing the stages), and the products
    themselves ran no faster on two threads. For short runs of small dense products. Nested and concurrent
    blocks count their users: the first entry saves the thread counts, the last
    exit restores them.
    """
    global _OPENBLAS, _BLAS_USERS, _BLAS_SAVED
    with _BLAS_LOCK:
        if _OPENBLAS is None:
            _OPENBLAS = _own_openblas()
        if _BLAS_USERS == 0:
            _BLAS_SAVED = [c.get_num_threads() for c in _OPENBLAS]
            for c in _OPENBLAS:
                c.set_num_threads(1)
        _BLAS_USERS += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS_USERS -= 1
            if _BLAS_USERS == 0:
                for c, n in zip(_OPENBLAS, _BLAS_SAVED, strict=True):
                    c.set_num_threads(n)
