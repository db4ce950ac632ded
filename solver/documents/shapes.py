"""The SHAPES document: named MOVEs at parameter value 1, the columns of a DOE plan.

``{"shapes": {NAME: MOVE, ...}}``. Each MOVE is :class:`solver.documents.move.Move`. A shape name is a
plan column: a non-empty string without control characters or blanks at either end, and none of
:data:`RESERVED` (the DOE summary's other columns). What needs the SPEC (handles it defines, one pivot
per handle) is checked by :func:`~solver.workflows.shapes.parse_shapes`.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field
from pydantic.config import JsonDict

from ..limits import SHAPE_NAME_MAX, SHAPES_MAX
from .move import Move
from .text import trimmed_name

__all__ = ["Shapes", "ShapeName", "ShapeMoves", "SHAPE_NAME_SCHEMA", "RESERVED", "SHAPES_MAX"]

#: Names a shape cannot take: the other columns of a DOE summary.
RESERVED = ("row", "inverted", "min_scaled_jacobian", "max_displacement", "constraint_residual_max", "file",
            "status")


def _plan_column(name: str) -> str:
    if name != name.strip() or any(ord(c) < 32 for c in name):
        raise ValueError(f"shape name {name!r} must be a non-empty string without surrounding blanks or "
                         "control characters")
    if name in RESERVED:
        raise ValueError(f"shape name {name!r} is reserved (a DOE summary column: {list(RESERVED)})")
    return name


#: A shape's name, which is its plan column.
ShapeName = Annotated[str, Field(min_length=1, max_length=SHAPE_NAME_MAX), AfterValidator(_plan_column)]
#: The JSON Schema of a shape name: what :data:`ShapeName` checks, stated for the OpenAPI document.
SHAPE_NAME_SCHEMA: JsonDict = {**trimmed_name(SHAPE_NAME_MAX), "not": {"anyOf": [
    trimmed_name(SHAPE_NAME_MAX)["not"], {"enum": list(RESERVED)}]}}
#: The ``shapes`` map of every document that carries SHAPES (this one, and the service's batch, study
#: and bounds requests): name -> MOVE at parameter value 1.
ShapeMoves = Annotated[dict[ShapeName, Move], Field(min_length=1, max_length=SHAPES_MAX,
                                                    json_schema_extra={"propertyNames": SHAPE_NAME_SCHEMA},
                                                    description="name -> MOVE at parameter value 1")]


class Shapes(BaseModel):
    """Named MOVEs at parameter value 1 (docs/guide/documents.md)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [
        {"shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}}}]})

    shapes: ShapeMoves

    def dump(self) -> dict[str, Any]:
        """The document as JSON-compatible data."""
        return {"shapes": {k: m.dump() for k, m in self.shapes.items()}}
