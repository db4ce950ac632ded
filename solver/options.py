"""How a precompute factors and solves: the speed layer as a value, not as switches found in hot paths.

A :class:`SolveOptions` is handed to :func:`~solver.precompute` (or set
around any factorization with :func:`using`); the factorization module and
the stacked solves read the one in effect through :func:`current`. The
environment, read once when :mod:`solver` is imported (:mod:`solver.environment`),
gives :data:`ENVIRONMENT`, the default for a caller that passes none:

===========================  ==========================================
``TETMORPH_SOLVER``          ``backend``: ``cholmod``, ``pardiso`` or ``scipy``
``TETMORPH_SUPERNODAL=0``    ``sweeps=False``
``TETMORPH_COLUMN_BASIS=0``  ``basis=False``
===========================  ==========================================

:meth:`SolveOptions.reference` is the plain path: the backends' own
solves (CHOLMOD, PARDISO, SuperLU), no supernodal sweeps, no column basis.
The tests compare the default path with it.

Precision is the SPEC's (``precision``) and the threads per solve are
:func:`solver.linalg.threads.configure`'s: both are part of the document or
of the process, not of a factorization.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator, Mapping
from contextvars import ContextVar
from dataclasses import asdict, dataclass, replace
from typing import Any

from .environment import START, read
from .errors import SpecError

__all__ = ["SolveOptions", "ENVIRONMENT", "current", "using", "BACKENDS", "add_solve_arguments", "from_arguments"]

#: ``auto`` picks CHOLMOD, then PARDISO, then SciPy, whichever is installed first.
BACKENDS = ("auto", "cholmod", "pardiso", "scipy")


@dataclass(frozen=True)
class SolveOptions:
    """The factorization choices of a precompute.

    Attributes
    ----------
    backend : {"auto", "cholmod", "pardiso", "scipy"}
        The symmetric positive definite backend. A name outside :data:`BACKENDS`
        (from the environment) is refused when a factorization is made
        (``FactorizationError`` ``unknown_backend``).
    sweeps : bool
        tetmorph's supernodal back-substitutions (:mod:`solver.linalg.supernodal`)
        and multifrontal LU where they apply; False keeps the backends' own solves.
    basis : bool
        Stacked solves through the interior column basis (DOE blocks).
    """

    backend: str = "auto"
    sweeps: bool = True
    basis: bool = True

    @classmethod
    def reference(cls, backend: str = "auto") -> SolveOptions:
        """The plain path: the backends' own solves, no sweeps, no column basis."""
        return cls(backend=backend, sweeps=False, basis=False)

    @classmethod
    def from_environment(cls, env: Mapping[str, str] | None = None) -> SolveOptions:
        """The options the ``TETMORPH_*`` variables of ``env`` describe (default: the process's, read at start-up)."""
        e = START if env is None else read(env)
        return cls(backend=e.backend, sweeps=e.sweeps, basis=e.basis)

    @classmethod
    def parse(cls, doc: Mapping[str, Any] | None, where: str = "solve_options") -> SolveOptions:
        """Options from a document (``{"backend": ..., "sweeps": ..., "basis": ...}``; absent keys default).

        Raises
        ------
        SpecError
            ``invalid_options`` for an unknown key, backend or a value of the wrong type.
        """
        if doc is None:
            return cls()
        if not isinstance(doc, Mapping):
            raise SpecError(f"{where} must be an object, got {type(doc).__name__}", code="invalid_options",
                            field=where)
        unknown = sorted(set(doc) - {"backend", "sweeps", "basis"})
        if unknown:
            raise SpecError(f"{where}: unknown field(s) {unknown}; known: backend, sweeps, basis",
                            code="invalid_options", field=where)
        backend = doc.get("backend", "auto")
        if backend not in BACKENDS:
            raise SpecError(f"{where}.backend {backend!r}: one of {list(BACKENDS)}", code="invalid_options",
                            field=f"{where}.backend")
        for k in ("sweeps", "basis"):
            if k in doc and not isinstance(doc[k], bool):
                raise SpecError(f"{where}.{k} must be true or false, got {doc[k]!r}", code="invalid_options",
                                field=f"{where}.{k}")
        return cls(backend=backend, sweeps=doc.get("sweeps", True), basis=doc.get("basis", True))

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


def add_solve_arguments(parser: argparse.ArgumentParser) -> None:
    """``--backend`` and ``--reference`` of the commands that factor a mesh."""
    parser.add_argument("--backend", choices=BACKENDS, help="symmetric backend (default: TETMORPH_SOLVER, else "
                        "auto: CHOLMOD, then PARDISO, then SciPy)")
    parser.add_argument("--reference", action="store_true", help="the plain reference path: the backends' own "
                        "solves, no supernodal sweeps, no column basis")


def from_arguments(args: argparse.Namespace) -> SolveOptions | None:
    """The options ``--backend`` and ``--reference`` ask for; None when neither is given (those in effect)."""
    backend = getattr(args, "backend", None)
    if getattr(args, "reference", False):
        return SolveOptions.reference(backend or current().backend)
    if backend is not None:
        return replace(current(), backend=backend)
    return None
