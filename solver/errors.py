"""Typed errors raised by :mod:`solver`.

Every error carries a machine-readable ``code`` and a ``details`` mapping
(counts, shapes, the first offending ids) next to its human-readable message,
so that the CLI and the REST service can report it without parsing text.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "SolverError",
    "InvalidMeshError",
    "UnsupportedElementError",
    "SpecError",
    "ConstraintError",
    "FactorizationError",
    "InversionError",
]

#: How many offending ids an error message lists before it says "...".
MAX_IDS_IN_MESSAGE = 10


def format_ids(ids: Any, limit: int = MAX_IDS_IN_MESSAGE) -> str:
    """Format the first ``limit`` ids of an array as ``[a, b, ...] (n in all)``.

    Examples
    --------
    >>> format_ids([3, 4, 5], limit=2)
    '[3, 4, ...] (3 in all)'
    >>> format_ids([7])
    '[7]'
    """
    ids = [int(i) for i in list(ids)]
    head = ", ".join(str(i) for i in ids[:limit])
    if len(ids) > limit:
        return f"[{head}, ...] ({len(ids)} in all)"
    return f"[{head}]"


class SolverError(Exception):
    """Base class of every error raised by tetmorph's solver.

    Parameters
    ----------
    message : str
        What is wrong, naming counts, shapes and the first offending ids.
    code : str, optional
        Stable machine-readable identifier (``"inverted_elements"``, ...).
    details : dict, optional
        JSON-serialisable facts backing the message.
    """

    default_code = "solver_error"

    def __init__(self, message: str, code: str | None = None, **details: Any) -> None:
        super().__init__(message)
        self.message = message
        self.code = code or self.default_code
        self.details = details

    def to_dict(self) -> dict[str, Any]:
        """Return ``{"type", "code", "message", "details"}`` for reports."""
        return {
            "type": type(self).__name__,
            "code": self.code,
            "message": self.message,
            "details": self.details,
        }


class InvalidMeshError(SolverError, ValueError):
    """The mesh cannot be deformed as given (bad coordinates, indices, volumes, topology)."""

    default_code = "invalid_mesh"


class UnsupportedElementError(InvalidMeshError):
    """The mesh holds element types that tetmorph does not deform yet."""

    default_code = "unsupported_element"


class SpecError(SolverError, ValueError):
    """A SPEC or MOVE document is malformed or names something that does not exist."""

    default_code = "invalid_spec"


class ConstraintError(SpecError):
    """The constraints leave the deformation undetermined or contradict each other."""

    default_code = "invalid_constraints"


class FactorizationError(SolverError, RuntimeError):
    """A sparse factorization failed (a singular or indefinite system)."""

    default_code = "factorization_failed"


class InversionError(SolverError):
    """A move inverted elements and the policy is ``"reject"``.

    Attributes
    ----------
    report : dict
        The full REPORT of the rejected update.
    """

    default_code = "inverted_elements"

    def __init__(self, message: str, report: dict[str, Any]) -> None:
        super().__init__(message, report=report)
        self.report = report
