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
:func:`update_threads` limits numba for callers that want one thread.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Iterator
from contextlib import contextmanager

import numba

__all__ = ["SOLVE_THREADS", "update_threads", "mkl_local_threads"]

#: Threads of a per-update solve (MKL and numba, this thread only).
SOLVE_THREADS = max(1, int(os.environ.get("TETMORPH_SOLVE_THREADS", "1") or 1))


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
