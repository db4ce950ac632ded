"""How a precompute factors and solves: the speed layer as a value, not as switches found in hot paths.

A :class:`SolveOptions` is handed to :func:`~solver.precompute` (or set
around any factorization with :func:`using`); the factorization module, the
positions' precompute and every solve read the one in effect through
:func:`current`. Where it comes from, lowest first:

1. the environment, read once when :mod:`solver` is imported
   (:mod:`solver.environment`; :data:`ENVIRONMENT`):

   ===========================  ==========================================
   ``TETMORPH_SOLVER``          ``backend``: ``cholmod``, ``pardiso`` or ``scipy``
   ``TETMORPH_SUPERNODAL=0``    ``sweeps=False``
   ``TETMORPH_COLUMN_BASIS=0``  ``basis=False``
   ===========================  ==========================================

2. the caller: ``precompute(..., options=)``, the command line's
   ``--backend``, ``--reference`` and ``--threads`` (:func:`from_arguments`),
   the service's settings;
3. the SPEC's ``solve_options`` (and its ``precision``), which replace what
   they name (:meth:`SolveOptions.updated`; :meth:`SolveOptions.overlay`
   validates a document first): a SPEC solves the same way wherever it
   runs. ``threads`` there only lowers the caller's cap.

:meth:`SolveOptions.reference` is the plain path: the backends' own
solves (CHOLMOD, PARDISO, SuperLU), no supernodal sweeps, no column basis.
The tests compare the default path with it. The process-wide cap of
:func:`solver.linalg.threads.configure` (the service's ``solver_threads``)
bounds every solve's threads as well.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator, Mapping
from contextvars import ContextVar
from dataclasses import asdict, dataclass, replace
from typing import Any

from .documents.choices import BACKENDS, PRECISIONS
from .environment import START, read
from .errors import SpecError
from .limits import THREADS_MAX

__all__ = ["SolveOptions", "ENVIRONMENT", "current", "using", "BACKENDS", "PRECISIONS", "add_solve_arguments",
           "from_arguments"]


@dataclass(frozen=True)
class SolveOptions:
    """The factorization and solve choices of a precompute.

    Attributes
    ----------
    backend : {"auto", "cholmod", "pardiso", "scipy"}
        The symmetric positive definite backend. A name outside :data:`BACKENDS`
        (from the environment) is refused when a factorization is made
        (``FactorizationError`` ``unknown_backend``).
    precision : {"mixed", "exact"}
        The split solve's interior mean-value system: a single-precision factor
        whose double-precision residual is checked (and refined once when it
        is not met), or a double-precision factor. Hard constraints are exact
        either way.
    threads : int
        Most threads one solve of this precompute uses; 0: as many as are free
        (:func:`solver.linalg.threads.solving`).
    sweeps : bool
        tetmorph's supernodal back-substitutions (:mod:`solver.linalg.supernodal`)
        and multifrontal LU where they apply; False keeps the backends' own solves.
    basis : bool
        Stacked solves through the interior column basis (DOE blocks).
    """

    backend: str = "auto"
    precision: str = "mixed"
    threads: int = 0
    sweeps: bool = True
    basis: bool = True

    @classmethod
    def reference(cls, backend: str = "auto", precision: str = "mixed") -> SolveOptions:
        """The plain path: the backends' own solves, no sweeps, no column basis."""
        return cls(backend=backend, precision=precision, sweeps=False, basis=False)

    @classmethod
    def from_environment(cls, env: Mapping[str, str] | None = None) -> SolveOptions:
        """The options the ``TETMORPH_*`` variables of ``env`` describe (default: the process's, read at start-up)."""
        e = START if env is None else read(env)
        return cls(backend=e.backend, sweeps=e.sweeps, basis=e.basis)

    @classmethod
    def parse(cls, doc: Any, where: str = "solve_options") -> SolveOptions:
        """Options from a document (``{"backend", "precision", "threads", "sweeps", "basis"}``; absent keys default).

        Validated by the SPEC's own model of it (:class:`solver.documents.spec.SolveSettings`).

        Raises
        ------
        SpecError
            ``invalid_options`` naming the field: an unknown key or backend, a value of the wrong type.
        """
        return cls().overlay(doc, where)

    def overlay(self, doc: Any, where: str = "solve_options") -> SolveOptions:
        """These options with what ``doc`` (a SPEC's ``solve_options``, or its model) names replaced.

        ``threads`` takes the smaller of two caps (0 is no cap).

        Raises
        ------
        SpecError
            ``invalid_options`` as :meth:`parse`.
        """
        if doc is None:
            return self
        from .documents.spec import SolveSettings
        from .documents.validation import validated

        try:
            given = validated(SolveSettings, doc, where).given()
        except SpecError as e:
            raise SpecError(e.message, code="invalid_options", **e.details) from None
        return self.updated(given)

    def updated(self, given: Mapping[str, Any]) -> SolveOptions:
        """These options with the validated fields ``given`` replaced (``threads``: the smaller cap)."""
        given = dict(given)
        caps = [t for t in (self.threads, given.pop("threads", 0)) if t]
        return replace(self, **given, threads=min(caps, default=0))

    def to_dict(self) -> dict[str, Any]:
        """Document form."""
        return asdict(self)


#: The environment's options (:data:`solver.environment.START`).
ENVIRONMENT = SolveOptions.from_environment()

_CURRENT: ContextVar[SolveOptions | None] = ContextVar("tetmorph_solve_options", default=None)


def current() -> SolveOptions:
    """The options in effect: those of the innermost :func:`using`, else :data:`ENVIRONMENT`."""
    return _CURRENT.get() or ENVIRONMENT


@contextlib.contextmanager
def using(options: SolveOptions | None) -> Iterator[SolveOptions]:
    """Make ``options`` (None: the ones in effect) current in this thread or task for the block."""
    opts = options or current()
    token = _CURRENT.set(opts)
    try:
        yield opts
    finally:
        _CURRENT.reset(token)


def _threads(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a whole number of threads, got {text!r}") from None
    if not 0 <= n <= THREADS_MAX:
        raise argparse.ArgumentTypeError(f"threads must be in [0, {THREADS_MAX}], got {n}")
    return n


def add_solve_arguments(parser: argparse.ArgumentParser) -> None:
    """``--backend``, ``--reference`` and ``--threads`` of the commands that factor a mesh."""
    parser.add_argument("--backend", choices=BACKENDS, help="symmetric backend (default: TETMORPH_SOLVER, else "
                        "auto: CHOLMOD, then PARDISO, then SciPy; a SPEC's solve_options.backend wins)")
    parser.add_argument("--reference", action="store_true", help="the plain reference path: the backends' own "
                        "solves, no supernodal sweeps, no column basis")
    parser.add_argument("--threads", type=_threads, help="most threads one solve uses (default 0: every free "
                        "core; a SPEC's solve_options.threads may lower it)")


def from_arguments(args: argparse.Namespace) -> SolveOptions | None:
    """The options ``--backend``, ``--reference`` and ``--threads`` ask for; None when none is given."""
    backend, threads = getattr(args, "backend", None), getattr(args, "threads", None)
    base = current()
    if getattr(args, "reference", False):
        base = SolveOptions.reference(backend or base.backend, base.precision)
    elif backend is None and threads is None:
        return None
    return replace(base, backend=backend or base.backend, threads=base.threads if threads is None else threads)
