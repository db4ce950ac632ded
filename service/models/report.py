"""The REPORT of an update (docs/reference/documents.md)."""

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
