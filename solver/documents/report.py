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
#: Examples of the schema.
EXAMPLES: list[Any] = [{
    "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0, "min_scaled_jacobian": 0.21,
    "constraint_residual_max": 0.0, "max_displacement": 4.0, "finite": True, "safe_fraction": 1.0, "clamped": False}]


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
        then optional with default None.
    """
    hints = typing.get_type_hints(record)
    spec: dict[str, Any] = {}
    for f in fields(record):
        description = f.metadata.get("description")
        if f.name in record.MAY_BE_LEFT_OUT:
            spec[f.name] = (hints[f.name] | None, Field(None, description=description))
        else:
            spec[f.name] = (hints[f.name], Field(description=description))
    config = ConfigDict(extra="allow", json_schema_extra={"examples": EXAMPLES})
    return create_model(name, __config__=config, __doc__=DOC, __module__=__name__, **spec)


if TYPE_CHECKING:
    class Report(BaseModel):
        """The model :func:`report_model` builds (its fields are known at run time only)."""

        model_config = ConfigDict(extra="allow")
else:
    Report = report_model()
