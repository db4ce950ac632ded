"""The REPORT of an update (docs/reference/documents.md) as a pydantic model, for the OpenAPI schema and the reference.

The REPORT is defined once, by the dataclass :class:`solver.documents.report_record.Report`
the library fills on every update. :func:`report_model` builds this model from its
fields: the same names in the same order, the types of their annotations, the
descriptions of their metadata. A key that :meth:`~solver.documents.report_record.Report.to_dict`
may leave out is optional here (default null); every other one is required. Further
keys are allowed (``extra="allow"``), so that a newer library's REPORT still validates.
"""

from __future__ import annotations

import typing
from dataclasses import fields
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, create_model

from .report_record import Report as ReportRecord

__all__ = ["Report", "report_model"]

#: The model's docstring: the description of the REPORT in the schema.
DOC = """What one MOVE did: inverted elements, quality, constraint residuals, timings.

Further fields (``repair``, ``quality``, quadratic-element figures, ...)
appear when they apply.
"""
#: Examples of the schema: the REPORT of a 3 mm pull of tests/data/bracket.inp's LOAD set (rounded).
EXAMPLES: list[Any] = [{
    "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0, "min_scaled_jacobian": 0.2128,
    "p01_scaled_jacobian": 0.2723, "min_scaled_jacobian_before": 0.2133, "p01_scaled_jacobian_before": 0.2753,
    "constraint_residual_max": 0.0, "constraint_residual_relative": 0.0,
    "constraint_rows": {"rows": 184, "dropped": 0}, "redundant_constraints": [], "conflicting_constraints": [],
    "max_displacement": 3.0, "solve_method": "null_space", "solve_mode": "split", "refine_steps": 0,
    "backend": "cholmod", "lu_backend": "scipy", "finite": True, "degenerate_at_rest": {"count": 0, "ids": []},
    "safe_fraction": 1.0, "clamped": False, "refactorized": False, "interior_precision": "double",
    "max_handle_displacement": 3.0, "max_free_displacement": 2.994,
    "timings": {"setup": {"assembly_ms": 269.6, "rotation_factorization_ms": 30.6,
                          "position_factorization_ms": 34.2, "total_ms": 347.1},
                "update": {"rhs_ms": 7.1, "solve_ms": 8.3, "check_ms": 0.16, "report_ms": 4.2,
                           "safe_fraction_ms": 0.0, "total_ms": 19.8}}}]


def report_model(record: type[ReportRecord] = ReportRecord, name: str = "Report") -> type[BaseModel]:
    """The pydantic model of the REPORT dataclass ``record``.

    Parameters
    ----------
    record : type
        :class:`~solver.documents.report_record.Report` or a dataclass derived from it.
    name : str
        The model's name (its name in the OpenAPI schema).

    Returns
    -------
    type
        A :class:`pydantic.BaseModel` with one field per field of ``record``: required, of the
        annotated type, unless :meth:`to_dict` may leave it out (``record.MAY_BE_LEFT_OUT``);
        then optional with default None. A number may be null: JSON has no NaN or infinity, and a
        result that is not finite (``finite: false``) is written with nulls.
    """
    hints = typing.get_type_hints(record)
    spec: dict[str, Any] = {}
    for f in fields(record):
        description = f.metadata.get("description")
        if f.name in record.MAY_BE_LEFT_OUT:
            spec[f.name] = (hints[f.name] | None, Field(None, description=description))
        else:
            kind = hints[f.name]
            nullable = float in typing.get_args(kind) or kind is float
            spec[f.name] = (kind | None if nullable else kind, Field(description=description))
    config = ConfigDict(extra="allow", json_schema_extra={"examples": EXAMPLES})
    return create_model(name, __config__=config, __doc__=DOC, __module__=__name__, **spec)


if TYPE_CHECKING:
    class Report(BaseModel):
        """The model :func:`report_model` builds (its fields are known at run time only)."""

        model_config = ConfigDict(extra="allow")
else:
    Report = report_model()
