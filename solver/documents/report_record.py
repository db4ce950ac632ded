"""The REPORT of one update, as the library fills it: a frozen dataclass, each field described.

This is the REPORT's one definition. :meth:`Report.to_dict` gives the JSON
document the CLI writes and the service returns;
:mod:`solver.documents.report` builds the pydantic model of the service's
OpenAPI schema and of the reference page (docs/reference/documents.md) from
these fields: their names, their annotated types and the ``description`` of
their metadata. A field added here is in the schema with no second edit.

It stays a plain dataclass, without pydantic: every update builds one, and
``import solver`` does not load pydantic.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any

__all__ = ["Report"]


@dataclass(frozen=True)
class Report:
    """The REPORT of one update. ``None`` optional fields are left out of :meth:`to_dict`."""

    inverted_elements: int = field(metadata={
        "description": "elements with signed volume <= 0 or |scaled Jacobian| <= 1e-12"})
    inverted_ids: list[int] = field(metadata={"description": "the first 100 of them"})
    degenerate_elements: int = field(metadata={"description": "elements of zero volume after the update"})
    min_scaled_jacobian: float | None = field(metadata={"description": "worst scaled Jacobian after the update"})
    p01_scaled_jacobian: float | None = field(metadata={
        "description": "first percentile of the scaled Jacobian after the update"})
    min_scaled_jacobian_before: float | None = field(metadata={"description": "worst scaled Jacobian at rest"})
    p01_scaled_jacobian_before: float | None = field(metadata={"description": "first percentile at rest"})
    constraint_residual_max: float = field(metadata={
        "description": "largest Euclidean gap between a fixed, handle or hard-row node and its target"})
    constraint_residual_relative: float = field(metadata={
        "description": "the same over the mesh's bounding-box diagonal"})
    constraint_rows: dict[str, int] = field(metadata={"description": "hard rows kept and dropped as dependent"})
    redundant_constraints: list[dict[str, Any]] = field(metadata={
        "description": "dropped rows that hold: system, kind, index, name, vertices"})
    conflicting_constraints: list[dict[str, Any]] = field(metadata={
        "description": "dropped rows that do not hold, with their residual"})
    max_displacement: float = field(metadata={"description": "largest vertex displacement from rest"})
    solve_method: str = field(metadata={"description": "null_space, kkt or penalty"})
    solve_mode: str = field(metadata={"description": "split or joint"})
    refine_steps: int = field(metadata={"description": "iterative refinement steps of the mixed-precision solve"})
    backend: str = field(metadata={"description": "the sparse backend of the boundary system"})
    lu_backend: str | None = field(metadata={"description": "the backend of the interior system"})
    finite: bool = field(metadata={"description": "true only when every number of the result is finite"})
    degenerate_at_rest: dict[str, Any] = field(default_factory=lambda: {"count": 0, "ids": []}, metadata={
        "description": "{count, ids}: elements already degenerate in the rest mesh (first 100 ids)"})
    safe_fraction: float = field(default=1.0, metadata={
        "description": "largest fraction of the MOVE that inverts nothing"})
    clamped: bool = field(default=False, metadata={"description": "whether the clamp policy scaled the MOVE"})
    refactorized: bool = field(default=False, metadata={
        "description": "whether this update factored anything (normally not)"})
    element_order: int | None = field(default=None, metadata={"description": "2 for quadratic meshes"})
    min_jacobian_ratio: float | None = field(default=None, metadata={
        "description": "quadratic meshes: smallest ratio of the smallest to the largest Jacobian determinant of "
                       "an element"})
    invalid_at_rest_elements: int | None = field(default=None, metadata={
        "description": "quadratic meshes: elements invalid already at rest"})
    midside_relaxed: dict[str, Any] | None = field(default=None, metadata={
        "description": "quadratic meshes: {midside_nodes, elements, ...} the mid-side relaxation touched"})
    safe_fraction_solves: int | None = field(default=None, metadata={
        "description": "solves the safe-fraction search took"})
    applied_fraction: float | None = field(default=None, metadata={
        "description": "the fraction of the MOVE applied (clamp)"})
    inverted_elements_unclamped: int | None = field(default=None, metadata={
        "description": "inverted elements of the full MOVE (clamp)"})
    repair: dict[str, Any] | None = field(default=None, metadata={"description": "what the repair did, when it ran"})
    quality: dict[str, Any] | None = field(default=None, metadata={
        "description": "{before, after} per-metric summaries (quality=full)"})
    interior_precision: str | None = field(default=None, metadata={
        "description": "the split solve's interior factor: single (SolveOptions.precision mixed) or double (exact)"})
    mean_value_residual: float | None = field(default=None, metadata={
        "description": "split solve: relative residual of the interior (mean value) system"})
    interior_refined: bool | None = field(default=None, metadata={
        "description": "split solve: whether the interior was refined in double precision"})
    enclosed_volume_ratio: float | None = field(default=None, metadata={
        "description": "closed triangle surfaces: enclosed volume after over before"})
    targets: dict[str, Any] | None = field(default=None, metadata={
        "description": "per SPEC target: {amount, nodes, iterations, max_distance, mean_distance}"})
    max_handle_displacement: float | None = field(default=None, metadata={
        "description": "largest displacement of a node of a handle or an edit (left out without either)"})
    max_free_displacement: float | None = field(default=None, metadata={
        "description": "largest displacement of a node neither fixed nor in a handle nor in an edit; above "
                       "max_handle_displacement, the morph moves something further than its handles"})
    timings: dict[str, Any] = field(default_factory=dict, metadata={
        "description": "setup stages and update stages in ms: rhs_ms, solve_ms, check_ms, report_ms, "
                       "safe_fraction_ms, total_ms"})

    #: Optional keys: left out when None (``midside_relaxed`` is kept for quadratic meshes).
    OPTIONAL = ("element_order", "min_jacobian_ratio", "invalid_at_rest_elements", "safe_fraction_solves",
                "applied_fraction", "inverted_elements_unclamped", "repair", "quality", "interior_precision",
                "mean_value_residual", "interior_refined", "enclosed_volume_ratio", "targets",
                "max_handle_displacement", "max_free_displacement")
    #: Keys :meth:`to_dict` may leave out: the optional ones, and ``midside_relaxed`` on a linear mesh.
    MAY_BE_LEFT_OUT = (*OPTIONAL, "midside_relaxed")

    def with_(self, **changes: Any) -> Report:
        """A copy with ``changes``."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The REPORT document (JSON-compatible)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and (f.name in self.OPTIONAL or (f.name == "midside_relaxed" and self.element_order != 2)):
                continue
            out[f.name] = v
        return out
