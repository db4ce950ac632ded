"""How many threads a solve uses: chosen per solve from the cores that are free.

An update reads factors and arrays once; it is bound by memory bandwidth and
by the barriers of its parallel kernels. On idle cores a second thread helps
the compiled kernels (``tetmorph_core``'s OpenMP loops, the two-subtree supernodal sweeps).
When the cores are shared, by another process or by other solves of this
one, a thread that waits at a barrier for a descheduled partner costs far
more than the second thread saved. So every solve asks :func:`solving` for
its threads when it starts:

* the cores this process may run on (its CPU affinity), capped by
  :func:`configure`'s ``max_threads`` (the process's cap) and by the
  ``threads`` of the :class:`~solver.options.SolveOptions` in effect (the
  precompute's);
* less the tasks that run on the machine right now and are not this
  process's solves (the kernel's count of runnable tasks, ``/proc/loadavg``);
* shared among this process's solves in flight.

The compiled kernels started by the calling thread get that count
(``tetmorph_core.set_num_threads`` sets OpenMP's count of the calling thread
only), and so do MKL's stacked
back-substitutions (``MKL_Set_Num_Threads_Local``). A narrow PARDISO
back-substitution (a single update) stays on one thread, as before.

Spinning waits are bounded at import of :mod:`solver` (:mod:`solver.environment`):
OpenMP's (libgomp, the compiled kernels') and OpenBLAS's helper threads
would otherwise spin on cores that other work needs.
``benchmarks/bench_contention.py`` measures all of it against the harmonic peer.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import tetmorph_core

from ..options import current as current_options

__all__ = ["WIDE_COLUMNS", "solve_threads", "solving", "configure", "current_threads", "in_flight",
           "in_flight_peak", "in_flight_reset", "free_threads", "cores", "one_blas_thread",
           "OpenBLAS", "openblas"]

#: Right-hand-side columns above which a back-substitution counts as stacked.
WIDE_COLUMNS = 6

_CONFIG = {"max_threads": 0}  # 0: every core of the affinity mask
_FLIGHT = threading.Lock()
_IN_FLIGHT = 0
_PEAK = 0
_LOCAL = threading.local()


def cores() -> int:
    """Cores this process may run on (its CPU affinity)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def configure(max_threads: int | None = None) -> None:
    """Cap the threads of any one solve (None or 0: every core; 1: serial solves).

    Raises
    ------
    ValueError
        ``max_threads`` negative.
    """
    n = int(max_threads or 0)
    if n < 0:
        raise ValueError(f"max_threads must be >= 0 (0: every core), got {max_threads}")
    _CONFIG["max_threads"] = n


def _running_tasks() -> int | None:
    """Tasks runnable on the machine right now (the kernel's count, the reader included), or None."""
    try:
        with open("/proc/loadavg", "rb") as f:
            return int(f.read().split()[3].split(b"/")[0])
    except (OSError, ValueError, IndexError):  # pragma: no cover - not Linux
        return None


def free_threads(solves: int = 1) -> int:
    """Threads for one of ``solves`` concurrent solves of this process, from the cores free now (at least 1)."""
    n = cores()
    cap = _CONFIG["max_threads"]
    if cap:
        n = min(n, cap)
    running = _running_tasks()
    if running is not None and running > solves:  # a second look: a passing kernel thread is not load
        running = min(running, _running_tasks() or running)
    others = 0 if running is None else max(0, running - solves)  # the solving threads are running themselves
    free = max(1, min(n, cores() - others))
    return max(1, free // max(1, solves))


def in_flight() -> int:
    """Solves of this process running now."""
    return _IN_FLIGHT


def in_flight_peak() -> int:
    """Most solves that ran at once since :func:`in_flight_reset`."""
    return _PEAK


def in_flight_reset() -> None:
    """Restart :func:`in_flight_peak` from the solves running now."""
    global _PEAK
    with _FLIGHT:
        _PEAK = _IN_FLIGHT


def current_threads() -> int:
    """Threads of the calling thread's solve (:func:`solving`), or of one solve now when outside one."""
    n = getattr(_LOCAL, "threads", 0)
    return n or free_threads(max(1, _IN_FLIGHT))


@contextmanager
def solving() -> Iterator[int]:
    """One solve: counted in flight, its compiled kernels on the threads free now; yields the count.

    NumPy's and SciPy's OpenBLAS run on one thread while any solve is in flight
    (:func:`one_blas_thread`).

    Nested blocks (a solve inside a solve of the same thread) keep the outer count.
    """
    global _IN_FLIGHT, _PEAK
    if getattr(_LOCAL, "threads", 0):
        yield _LOCAL.threads
        return
    with _FLIGHT:
        _IN_FLIGHT += 1
        _PEAK = max(_PEAK, _IN_FLIGHT)
        share = _IN_FLIGHT
    k = min(free_threads(share), tetmorph_core.max_threads())
    cap = current_options().threads  # the precompute's own cap (SolveOptions.threads)
    if cap:
        k = min(k, cap)
    prev = tetmorph_core.get_num_threads()
    tetmorph_core.set_num_threads(k)
    _LOCAL.threads = k
    try:
        with one_blas_thread():  # an update's dense products are small; no helper left spinning after them
            yield k
    finally:
        _LOCAL.threads = 0
        tetmorph_core.set_num_threads(prev)
        with _FLIGHT:
            _IN_FLIGHT -= 1


def solve_threads(columns: int, stacked_before: bool = False) -> int:
    """MKL threads for a back-substitution of ``columns`` right-hand sides.

    A narrow one (a single update) runs on one thread: it is bound by memory
    traffic. A stacked one (more than :data:`WIDE_COLUMNS` columns) reads the
    factor once for all its columns and gets :func:`current_threads`.
    ``stacked_before``: the factor has made a stacked solve; PARDISO keeps a
    factor's earlier thread count for its later solves, so a refinement step
    or a short last block keeps the stacked count too.
    """
    return current_threads() if stacked_before or columns > WIDE_COLUMNS else 1


class OpenBLAS:
    """One OpenBLAS library's thread count, read and set through its own C functions.

    Not threadpoolctl's ``set_num_threads``: since threadpoolctl 3.8 only the first
    thread that sets a pthreads OpenBLAS may set it again while that thread lives,
    and a call from any other thread silently does nothing. In a process where a
    long-lived thread set a count first (a service's build or solve pool, CHOLMOD's
    first factor in :mod:`solver.linalg.factorization`), every other thread's
    block would leave OpenBLAS on all its threads, or leave it on one for good.
    OpenBLAS's own ``openblas_set_num_threads`` sets the process-wide count
    (pthreads builds) from any thread.
    """

    __slots__ = ("filepath", "_lib")

    def __init__(self, filepath: str) -> None:
        self.filepath = filepath
        self._lib = tetmorph_core.OpenBLASThreads(filepath)  # OSError: not loaded, or no thread functions

    def get_num_threads(self) -> int:
        """The library's thread count (process-wide)."""
        return int(self._lib.get_num_threads())

    def set_num_threads(self, n: int) -> None:
        """Set the library's thread count (process-wide), from any thread."""
        self._lib.set_num_threads(int(n))


def _package_homes() -> tuple[str, ...]:
    """The prefix of this Python and the folders numpy and scipy are installed in (their wheels' libraries)."""
    import numpy
    import scipy

    return tuple(os.path.realpath(p) + os.sep for p in
                 (sys.prefix, *(os.path.dirname(os.path.dirname(m.__file__ or "")) for m in (numpy, scipy))))


#: Names an OpenBLAS is loaded under: its own, the system's BLAS alternative, scipy-openblas's wheels.
_OPENBLAS_NAMES = ("libopenblas", "libblas", "libscipy_openblas")


def openblas(own: bool = True) -> list[OpenBLAS]:
    """The OpenBLAS libraries loaded in this process: numpy's and scipy's own, or the others.

    ``own``: those inside this Python's prefix or numpy's and scipy's install folders (their
    wheels'; the folders count too when the packages come from another environment, through a
    path file or ``PYTHONPATH``); ``own=False``: the others (the system one CHOLMOD links).
    A loaded object counts when its file name starts like an OpenBLAS's and it has OpenBLAS's
    thread functions.
    """
    found = []
    homes = _package_homes()
    for path in tetmorph_core.loaded_objects()[2]:
        if not os.path.basename(path).startswith(_OPENBLAS_NAMES):
            continue
        if os.path.realpath(path).startswith(homes) == own:
            try:
                found.append(OpenBLAS(path))
            except OSError:  # a reference BLAS, or an OpenBLAS without the thread API
                pass
    return found


def _loads() -> tuple[int, int]:
    """Shared objects loaded and unloaded so far in this process (glibc's dlpi_adds, dlpi_subs)."""
    adds, subs = tetmorph_core.load_counts()
    return adds, subs


def _own_openblas() -> list[OpenBLAS]:
    """NumPy's and SciPy's own OpenBLAS (inside this Python's prefix; not CHOLMOD's system one)."""
    return openblas(own=True)


_OPENBLAS: list[OpenBLAS] | None = None  # numpy's and scipy's own OpenBLAS, found again when a library loads
_OPENBLAS_LOADS: tuple[int, int] | None = None
_BLAS_LOCK = threading.Lock()
_BLAS_USERS = 0
_BLAS_SAVED: list[int] = []


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """NumPy's and SciPy's OpenBLAS on one thread inside the block (process-wide while any thread is inside).

    OpenBLAS's helper threads keep spinning for a while after each call. On two
    cores a spinning helper takes a core from the compiled kernel that follows (in a
    DOE block at 1M tets, the residual check after the column basis's small
    products, seen in a throw-away script timing the stages), and the products
    themselves ran no faster on two threads. For short runs of small dense products. Nested and concurrent
    blocks count their users: the first entry saves the thread counts, the last
    exit restores them. Any thread may set and restore them (:class:`OpenBLAS`),
    and the libraries are looked up again when the process has loaded a shared
    object since the last look.
    """
    global _OPENBLAS, _OPENBLAS_LOADS, _BLAS_USERS, _BLAS_SAVED
    with _BLAS_LOCK:
        if _BLAS_USERS == 0:
            loads = _loads()
            if _OPENBLAS is None or loads is None or loads != _OPENBLAS_LOADS:
                _OPENBLAS, _OPENBLAS_LOADS = _own_openblas(), loads
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
                for c, n in zip(_OPENBLAS or [], _BLAS_SAVED, strict=True):
                    c.set_num_threads(n)
