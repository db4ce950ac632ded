"""The process environment, read here once, when :mod:`solver` is imported.

Two things happen at start-up, before OpenMP, MKL and OpenBLAS load:

* :func:`apply_spin_settings` bounds the spin waits of the threading
  runtimes. OpenMP (GNU libgomp, which the compiled kernels of
  ``tetmorph_core`` and MKL's ``gnu_thread`` layer share) lets a thread that reaches a barrier or
  ends a parallel region spin for a long while before it sleeps. On idle
  cores that saves a wake-up; on shared cores the spinning thread takes the
  core that another process or another of this process's solves needs, and
  every barrier then waits for a descheduled partner. It also makes this
  process's own idle workers look busy to
  :func:`solver.linalg.threads.free_threads`. OpenBLAS's helper threads spin
  after each call for the same reason. Each runtime reads its setting once,
  when it loads, so only what the environment leaves unset is set (a user's
  own ``GOMP_SPINCOUNT``, ``OMP_WAIT_POLICY`` or ``OPENBLAS_THREAD_TIMEOUT``
  wins). ``benchmarks/bench_contention.py`` measures the effect.
* :data:`START` reads every variable the library honours into one
  :class:`Environment`. Code elsewhere takes its defaults from it and never
  looks at ``os.environ`` itself: :data:`solver.options.ENVIRONMENT` (the
  solve options of a caller that passes none), the MKL library
  (:func:`solver.linalg.pardiso.mkl_runtime`), the allocator of batch runs
  (:func:`solver.workflows.batch_memory.keep_freed_memory`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["SPIN_SETTINGS", "apply_spin_settings", "Environment", "read", "START"]

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


@dataclass(frozen=True)
class Environment:
    """What the library's environment variables ask for.

    Attributes
    ----------
    backend : str
        ``TETMORPH_SOLVER`` (lower case; ``"auto"`` when unset): the symmetric backend.
    sweeps : bool
        False when ``TETMORPH_SUPERNODAL=0``: the backends' own back-substitutions.
    basis : bool
        False when ``TETMORPH_COLUMN_BASIS=0``: no interior column basis for stacked solves.
    mkl_rt : str or None
        ``PYPARDISO_MKL_RT``, else ``TETMORPH_MKL_RT``: the path of MKL's ``libmkl_rt``, when it is
        not the one installed beside Python.
    batch_malloc : bool
        False when ``TETMORPH_BATCH_MALLOC=0``: batch runs leave glibc's allocator as it is.
    """

    backend: str = "auto"
    sweeps: bool = True
    basis: bool = True
    mkl_rt: str | None = None
    batch_malloc: bool = True


def read(env: Mapping[str, str] | None = None) -> Environment:
    """The :class:`Environment` that ``env`` (default ``os.environ``) describes."""
    env = os.environ if env is None else env

    def on(name: str) -> bool:
        return env.get(name, "1").strip() != "0"

    return Environment(backend=env.get("TETMORPH_SOLVER", "").strip().lower() or "auto",
                       sweeps=on("TETMORPH_SUPERNODAL"), basis=on("TETMORPH_COLUMN_BASIS"),
                       mkl_rt=env.get("PYPARDISO_MKL_RT") or env.get("TETMORPH_MKL_RT") or None,
                       batch_malloc=on("TETMORPH_BATCH_MALLOC"))


apply_spin_settings()
#: The environment of this process, read once at start-up.
START = read()
