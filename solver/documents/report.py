"""The REPORT of an update (docs/reference/documents.md): what the library answers for each MOVE.

The library writes the REPORT as a dict; this model describes it, field by field, for the service's
OpenAPI schema and the reference pages. ``tests/solver/documents/test_report.py`` checks that every
field the library writes is declared here.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["Report"]


class Report(BaseModel):
    """What one MOVE did: inverted elements, quality, constraint residuals, timings.

    Further fields (``repair``, ``quality``, quadratic-element figures, ...)
    appear when they apply.
    """

    model_config = ConfigDict(extra="allow", json_schema_extra={"examples": [{
        "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0, "min_scaled_jacobian": 0.21,
        "constraint_residual_max": 0.0, "max_displacement": 4.0, "finite": True, "safe_fraction": 1.0,
        "clamped": False}]})

    inverted_elements: int = Field(description="elements with signed volume <= 0 or |scaled Jacobian| <= 1e-12")
    inverted_ids: list[int] = Field(default_factory=list, description="the first 100 of them")
    degenerate_elements: int | None = None
    min_scaled_jacobian: float | None = None
    p01_scaled_jacobian: float | None = None
    min_scaled_jacobian_before: float | None = None
    p01_scaled_jacobian_before: float | None = None
    constraint_residual_max: float | None = None
    constraint_residual_relative: float | None = None
    max_displacement: float | None = None
    max_handle_displacement: float | None = Field(None, description="largest displacement of a handle's node")
    max_free_displacement: float | None = Field(None, description="largest displacement of a node neither fixed "
                                                "nor in a handle; above max_handle_displacement, the morph moves "
                                                "something further than its handles")
    finite: bool | None = Field(None, description="true only when every number of the result is finite")
    constraint_rows: dict[str, int] | None = None
    redundant_constraints: list[dict[str, Any]] = Field(default_factory=list)
    conflicting_constraints: list[dict[str, Any]] = Field(default_factory=list)
    safe_fraction: float | None = Field(None, description="largest fraction of the MOVE that inverts nothing")
    clamped: bool | None = None
    applied_fraction: float | None = None
    inverted_elements_unclamped: int | None = None
    solve_method: str | None = None
    solve_mode: str | None = None
    backend: str | None = None
    lu_backend: str | None = None
    refactorized: bool | None = None
    timings: dict[str, Any] | None = None
    refine_steps: int | None = Field(None, description="iterative refinement steps of the mixed-precision solve")
    degenerate_at_rest: dict[str, Any] | None = Field(None, description="{count, ids}: elements already degenerate "
                                                      "in the rest mesh (first 100 ids)")
    element_order: int | None = Field(None, description="2 for quadratic meshes")
    min_jacobian_ratio: float | None = Field(None, description="quadratic meshes: smallest ratio of the smallest to "
                                             "the largest Jacobian determinant of an element")
    invalid_at_rest_elements: int | None = Field(None, description="quadratic meshes: elements invalid already at rest")
    midside_relaxed: dict[str, Any] | None = Field(None, description="quadratic meshes: {midside_nodes, elements, "
                                                   "...} the mid-side relaxation touched")
    safe_fraction_solves: int | None = Field(None, description="solves the safe-fraction search took")
    repair: dict[str, Any] | None = Field(None, description="what the repair did, when it ran")
    quality: dict[str, Any] | None = Field(None, description="{before, after} per-metric summaries (quality=full)")
    interior_precision: str | None = Field(None, description="the interior solve's precision: mixed or exact")
    mean_value_residual: float | None = Field(None, description="split solve: relative residual of the interior "
                                              "(mean value) system")
    interior_refined: bool | None = Field(None, description="split solve: whether the interior was refined in "
                                          "double precision")
    enclosed_volume_ratio: float | None = Field(None, description="closed triangle surfaces: enclosed volume after "
                                                "over before")
    targets: dict[str, Any] | None = Field(None, description="per SPEC target: {amount, nodes, iterations, "
                                           "max_distance, mean_distance}")
