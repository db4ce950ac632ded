"""Batches and bounds of shape variables: the request bodies.

A batch morphs every row of a PLAN through a session's factorization (the
``tetmorph doe`` of the service); bounds search each shape's largest values
that invert nothing (``tetmorph bounds``). Shapes are MOVE documents at
parameter value 1 (docs/guide/workflows.md).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictStr

from solver.documents.move import Move
from solver.documents.numbers import INTEGRAL
from solver.documents.shapes import SHAPE_NAME_SCHEMA, ShapeMoves
from solver.limits import BLOCK_MAX, BOUNDS_TOL_MAX, PLAN_TEXT_MAX, SHAPE_VALUE_MAX, SHAPES_MAX

from .formats import MESH_FORMAT_VALUES

__all__ = ["PlanTable", "BatchCreate", "StudyCreate", "BoundsQuery", "shapes_document"]

_STRICT = ConfigDict(extra="forbid", strict=True)

#: Rows per stacked back-substitution.
Block = Annotated[int, Field(strict=True, ge=1, le=BLOCK_MAX), INTEGRAL]
#: A PLAN as the text of its CSV file.
PlanText = Annotated[str, Field(max_length=PLAN_TEXT_MAX)]


class PlanTable(BaseModel):
    """A PLAN as JSON: column names (shape names) and one row of numbers per variant."""

    model_config = _STRICT
    columns: list[StrictStr] = Field(min_length=1, max_length=SHAPES_MAX, description="shape names, each once",
                                     json_schema_extra={"uniqueItems": True, "items": SHAPE_NAME_SCHEMA})
    rows: list[list[Any]] = Field(min_length=1, description="one list of numbers per variant, one number per "
                                  "column; the row count is bounded by TETMORPH_BATCH_MAX_ROWS",
                                  json_schema_extra={"items": {"type": "array", "minItems": 1,
                                                               "maxItems": SHAPES_MAX,
                                                               "items": {"type": "number"}}})


class BatchCreate(BaseModel):
    """Morph every row of a PLAN: one deck per row and a summary, as a zip."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}},
        "plan": {"columns": ["bend"], "rows": [[0.5], [1.0]]}, "format": "inp"}]})

    shapes: ShapeMoves
    plan: PlanTable | PlanText = Field(
        description="{columns, rows}, or the text of a PLAN CSV file (header of shape names)")
    format: StrictStr | None = Field(None, max_length=40, description="deck format name or extension; "
                                     "default the mesh's own (byte-faithful but the node coordinates)",
                                     json_schema_extra={"enum": [*MESH_FORMAT_VALUES, None]})
    engine: Literal["local", "ray"] = Field("local", description="local: this replica's factorization, "
                                            "blocks between the session's MOVEs; ray: actors of the Ray "
                                            "cluster of TETMORPH_RAY_ADDRESS")
    block: Block = Field(16, description="rows per stacked back-substitution")
    inversion: Literal["warn", "reject", "clamp"] | None = Field(
        None, description="override the SPEC's policy; 'reject' writes no deck for an inverting row")

    def shapes_doc(self) -> dict[str, Any]:
        """The SHAPES document for :func:`solver.workflows.parse_shapes`."""
        return shapes_document(self.shapes)


class StudyCreate(BaseModel):
    """Morph every row of a PLAN, run the FE solver on each deck and table its responses (``tetmorph study``)."""

    model_config = ConfigDict(extra="forbid", strict=True, json_schema_extra={"examples": [{
        "shapes": {"bend": {"handles": {"tip": {"translation": [0, 0, 4]}}}},
        "plan": {"columns": ["bend"], "rows": [[0.0], [0.5]]}, "solver": "ccx"}]})

    shapes: ShapeMoves
    plan: PlanTable | PlanText = Field(
        description="{columns, rows}, or the text of a PLAN CSV file (header of shape names)")
    solver: StrictStr = Field(min_length=1, max_length=64, description="a solver name of the service's "
                              "TETMORPH_STUDY_SOLVERS (the service runs its configured command)")
    response: Literal["ccx"] = Field("ccx", description="the response reader: ccx (CalculiX .dat: "
                                     "max_displacement, max_mises, mass, freq_k)")
    timeout_s: float | None = Field(None, gt=0, allow_inf_nan=False, description="seconds per solver run "
                                    "(at most, and by default, TETMORPH_STUDY_TIMEOUT_S)")
    format: StrictStr | None = Field(None, max_length=40, description="deck format name or extension; "
                                     "default the mesh's own", json_schema_extra={"enum": [*MESH_FORMAT_VALUES, None]})
    block: Block = Field(16, description="rows per stacked back-substitution")
    inversion: Literal["warn", "reject", "clamp"] = Field(
        "reject", description="the morph's policy; 'reject' (default) records an inverting row, unsolved")

    def shapes_doc(self) -> dict[str, Any]:
        """The SHAPES document for :func:`solver.workflows.parse_shapes`."""
        return shapes_document(self.shapes)


class BoundsQuery(BaseModel):
    """Per shape, the largest positive and negative value inverting nothing."""

    model_config = _STRICT
    shapes: ShapeMoves
    range: list[Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-SHAPE_VALUE_MAX,
                                       le=SHAPE_VALUE_MAX)]] | None = Field(
        None, min_length=2, max_length=2, description="[lo, hi] with lo <= 0 <= hi; default 1, 2, 4, ... 1024",
        json_schema_extra={"prefixItems": [{"maximum": 0}, {"minimum": 0}]})
    tol: Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0, le=BOUNDS_TOL_MAX)] = 1e-3

    def shapes_doc(self) -> dict[str, Any]:
        """The SHAPES document."""
        return shapes_document(self.shapes)


def shapes_document(shapes: dict[str, Move]) -> dict[str, Any]:
    """``{"shapes": {name: MOVE}}`` holding the validated MOVE models themselves.

    :func:`solver.workflows.parse_shapes` checks the names and takes the models as they are: a shape's
    MOVE is not validated again.
    """
    return {"shapes": dict(shapes)}
