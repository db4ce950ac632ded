"""The quality check's answer (``GET /v1/meshes/{id}/check``, ``GET /v1/sessions/{id}/check``).

The criteria and presets are the library's (:mod:`solver.validity.criteria`); their
names are spelled out here for the schema, and a test holds the two lists equal.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from solver.limits import MAX_CELLS

__all__ = ["CriterionName", "PresetName", "CriterionDoc", "QualityCheckDoc", "CHECK_IDS_DEFAULT", "CHECK_IDS_MAX"]

#: The keys of :data:`solver.validity.criteria.CRITERIA`.
CriterionName = Literal["min_scaled_jacobian", "min_scaled_jacobian_ip", "max_aspect_ratio", "min_dihedral",
                        "max_dihedral", "min_volume_ratio", "max_volume_ratio"]
#: The keys of :data:`solver.validity.criteria.PRESETS`.
PresetName = Literal["tetmorph", "abaqus", "calculix", "nastran"]
#: Failing ids answered per criterion unless ``ids`` says otherwise, and the most it may ask.
CHECK_IDS_DEFAULT = 1000
CHECK_IDS_MAX = MAX_CELLS


class CriterionDoc(BaseModel):
    """One criterion's outcome."""

    name: CriterionName
    measure: str = Field(description="the per-element measure it reads (scaled_jacobian, aspect_ratio, ...)")
    sense: Literal["min", "max"] = Field(description="min: elements below the threshold fail; max: above")
    threshold: float | None = Field(description="null: not checked")
    checked: bool
    applicable: int = Field(description="elements the measure applies to (0: a tet10 measure on linear "
                                        "elements, a volume ratio without rest positions)")
    failing: int = Field(description="how many elements fail")
    passed: bool
    worst: float | None = Field(description="the worst value over the applicable elements")
    worst_element: int | None = Field(description="its element, by the deck's id")
    ids: list[int] = Field(description="the failing elements' deck ids, ascending; the first `ids` of them")


class QualityCheckDoc(BaseModel):
    """Per criterion: threshold, failing count, worst value and element, the failing deck ids."""

    preset: PresetName
    passed: bool = Field(description="no element fails a checked criterion")
    elements: int
    failing_elements: int = Field(description="elements failing at least one criterion")
    deformed: bool = Field(description="checked at a session's current positions (volume ratio against rest)")
    criteria: list[CriterionDoc]
