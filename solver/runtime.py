"""Bounded spin waits for the threading runtimes, set before they load.

OpenMP (GNU libgomp, which numba's ``omp`` threading layer and MKL's
``gnu_thread`` layer share) lets a thread that reaches a barrier or ends a
parallel region spin for a long while before it sleeps. On idle cores that
saves a wake-up; on shared cores the spinning thread takes the core that
another process or another of this process's solves needs, and every
barrier then waits for a descheduled partner. It also makes this process's
own idle workers look busy to :func:`solver.linalg.threads.free_threads`.
OpenBLAS's helper threads spin after each call for the same reason.

Each runtime reads its setting once, when it loads, so this module runs
first in :mod:`solver` and only sets what the environment does not already
set (a user's own ``GOMP_SPINCOUNT``, ``OMP_WAIT_POLICY`` or
``OPENBLAS_THREAD_TIMEOUT`` wins). Where a runtime was loaded before
:mod:`solver` was imported, its setting stays what it was; only speed under
load is at stake. ``benchmarks/bench_contention.py`` measures the effect.
"""

from __future__ import annotations

import os

__all__ = ["SPIN_SETTINGS", "apply_spin_settings"]

#: Environment defaults: libgomp spins about this many iterations (microseconds,
#: not its default's hundreds) before it sleeps; OpenBLAS's helpers about 2^16 cycles.
SPIN_SETTINGS = {"GOMP_SPINCOUNT": "10000", "OPENBLAS_THREAD_TIMEOUT": "16"}


def apply_spin_settings() -> dict[str, str]:
    """Set :data:`SPIN_SETTINGS` where the environment leaves them unset; returns what was set."""
    done: dict[str, str] = {}
    if "OMP_WAIT_POLICY" in os.environ:  # the user chose a policy; libgomp derives its spin count from it
        return done
    for k, v in SPIN_SETTINGS.items():
        if k not in os.environ:
            os.environ[k] = v
            done[k] = v
    return done


apply_spin_settings()
