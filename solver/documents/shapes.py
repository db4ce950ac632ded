"""The SHAPES document: named MOVEs at parameter value 1, the columns of a DOE plan.

``{"shapes": {NAME: MOVE, ...}}``. Each MOVE is :class:`solver.documents.move.Move`. A shape name is a
plan column: a non-empty string without control characters or blanks at either end, and none of
:data:`RESERVED` (the DOE summary's other columns). What needs the SPEC (handles it defines, one pivot
per handle) is checked by :func:`~solver.workflows.shapes.parse_shapes`.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from .move import Move

__all__ = ["Shapes", "ShapeName", "RESERVED", "SHAPES_MAX"]

#: Names a shape cannot take: the other columns of a DOE summary.
RESERVED = ("row", "inverted", "min_scaled_jacobian", "max_displacement", "constraint_residual_max", "file",
            "status")
#: Most shapes in one document.
SHAPES_MAX = 1000


def _plan_column(name: str) -> str:
    if name != name.strip() or any(ord(c) < 32 for c in name):
        raise ValueError(f"shape name {name!r} must be a non-empty string without surrounding blanks or "
                         "control characters")
    if name in RESERVED:
        raise ValueError(f"shape name {name!r} is reserved (a DOE summary column: {list(RESERVED)})")
    return name


#: A shape's name, which is its plan column.
ShapeName = Annotated[str, Field(min_length=1, max_length=200), AfterValidator(_plan_column)]


class Shapes(BaseModel):
    """Named MOVEs at parameter value 1 (docs/guide/documents.md)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [
        {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}}}]})

    shapes: dict[ShapeName, Move] = Field(min_length=1, max_length=SHAPES_MAX,
                                          description="name -> MOVE at parameter value 1")

    def dump(self) -> dict[str, Any]:
        """The document as JSON-compatible data."""
        return {"shapes": {k: m.dump() for k, m in self.shapes.items()}}
