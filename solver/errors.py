"""Typed errors raised by :mod:`solver`.

Every error carries a machine-readable ``code`` and a ``details`` mapping
(counts, shapes, the first offending ids) next to its human-readable message,
so that the CLI and the REST service can report it without parsing text.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "MAX_IDS",
    "SolverError",
    "InvalidMeshError",
    "UnsupportedElementError",
    "UnreadableFileError",
    "TopologyError",
    "LossyWriteError",
    "SpecError",
    "ConstraintError",
    "FactorizationError",
    "InversionError",
]

#: How many offending ids an error message lists before it says "...".
MAX_IDS_IN_MESSAGE = 10
#: How many ids an error's details and a REPORT list (inverted elements, offending nodes).
MAX_IDS = 100


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


class UnreadableFileError(InvalidMeshError):
    """A mesh file cannot be read, and the message says why.

    Empty, truncated, another format than its name says, a surface where a
    volume mesh is expected, or a deck that names nodes it never defines.

    Codes: ``empty_file``, ``truncated_file``, ``wrong_format`` (details ``detected``, the
    format the content looks like, or None), ``surface_not_volume``, ``undefined_node``
    (details ``element``, ``node``, ``line``), ``no_nodes``, ``undefined_coordinate_system``,
    ``cyclic_coordinate_system``, ``unsupported_coordinate_system``, ``invalid_coordinate_system``
    (a Nastran GRID's CP system that cannot be placed; details ``grid``, ``system``, ``chain``),
    ``too_many_points``, ``too_many_cells``, ``too_many_bytes`` (details ``declared``, ``bound``,
    ``setting``: :mod:`solver.io.bounds`), ``too_large_to_read`` (the reader ran out of memory),
    ``external_reference`` (an XDMF file naming data outside its folder, an HDF5 file with external
    links, virtual datasets or external storage),
    ``include_outside``, ``include_missing``, ``bad_include`` (a deck's ``*INCLUDE`` of a file outside
    its folder, one not beside it, or one with no file name, that includes itself or nests too deep;
    details ``include``), ``bad_deck``, ``bad_node_line``, ``bad_element_line``, ``bad_set``,
    ``bad_instance``, ``duplicate_node``, ``duplicate_part``, ``unsupported_keyword`` (an Abaqus deck
    Abaqus itself would refuse, or that tetmorph does not read; details ``line``, and ``in``, the
    included file),
    ``unreadable_file`` (anything else; the reader's own words are in the message).
    """

    default_code = "unreadable_file"


class TopologyError(InvalidMeshError):
    """The elements do not form a manifold body.

    Edges or vertices where the boundary pinches, or coincident nodes that split a body.

    Codes: ``non_manifold_boundary`` (edges in more than two boundary faces),
    ``non_manifold_vertex`` (details ``vertices``), ``duplicate_nodes`` (details ``pairs``),
    ``inconsistent_orientation``.
    """

    default_code = "non_manifold"


class LossyWriteError(InvalidMeshError):
    """Writing to the target format would drop something the mesh carries.

    Elements, an element type, set names, data arrays: ``details["losses"]`` lists each item.

    Pass ``lossy=True`` to :func:`solver.io.write_mesh` (CLI ``--lossy``) to accept the loss.
    """

    default_code = "lossy_write"


class SpecError(SolverError, ValueError):
    """A SPEC or MOVE document is malformed or names something that does not exist.

    Codes: ``node_on_axis``, ``no_intersection``, ``off_arc`` (raised through a helper for a
    radius, map or fillet edit's nodes, details ``ids``), besides the codes raised where they are
    named.
    """

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
