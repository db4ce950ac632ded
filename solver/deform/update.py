"""One update end to end: positions, policy, quality, timings, and the errors a policy raises."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..constraints.move import ResolvedMove
from ..errors import ConstraintError, InversionError, SpecError, format_ids
from ..validity.quality import element_quality, summarize_quality
from .conflicts import conflict_details
from .constraint_set import entry_text
from .policy import INVERSION_POLICIES, apply_policy
from .precompute import DeformData
from .report import Report, all_finite
from .solve import Solved

__all__ = ["DeformResult", "update", "check_options"]


@dataclass(frozen=True, eq=False)
class DeformResult:
    """Result of one update.

    Attributes
    ----------
    V : (n, 3) float64 array
        Deformed positions in file order (unreferenced vertices unchanged).
    report : dict
        The REPORT document (``report_data.to_dict()``).
    move : ResolvedMove
        The MOVE that was applied (the scaled one when the policy clamped it).
    cell_quality : dict of str to (m,) array, optional
        Per-element metrics (``quality="full"``), see :func:`solver.validity.quality.element_quality`.
    report_data : Report, optional
        The REPORT as a dataclass.
    """

    V: np.ndarray
    report: dict[str, Any]
    move: ResolvedMove | None = None
    cell_quality: dict[str, np.ndarray] | None = None
    report_data: Report | None = None


def check_options(policy: str, quality: str) -> None:
    """Refuse an unknown inversion policy or quality level."""
    if policy not in INVERSION_POLICIES:
        raise SpecError(f"inversion policy must be one of {list(INVERSION_POLICIES)}, got {policy!r}",
                        field="inversion")
    if quality not in ("basic", "full"):
        raise SpecError(f"quality must be 'basic' or 'full', got {quality!r}", field="quality")


def update(data: DeformData, mv: ResolvedMove, solved: Solved, policy: str, quality: str, repair: bool,
           times: tuple[float, float, float]) -> DeformResult:
    """Apply the policy to a solve, add quality and timings, and raise what the policy refuses.

    Parameters
    ----------
    data : DeformData
    mv : ResolvedMove
    solved : Solved
        Positions of ``mv``.
    policy : {"warn", "reject", "clamp"}
    quality : {"basic", "full"}
    repair : bool
    times : (t0, t1, t2)
        ``perf_counter`` at the start, after parsing, after the solve.

    Returns
    -------
    DeformResult

    Raises
    ------
    ConstraintError
        The MOVE makes hard constraints conflict and ``SPEC.conflicts`` is ``"reject"``.
    InversionError
        Elements were inverted and the policy is ``"reject"``.
    """
    t0, t1, t2 = times
    out = apply_policy(data, solved, mv, policy, repair)
    rep, P = out.report, out.solved.P
    cell_q = None
    if quality == "full" and not data.mesh.is_surface:
        mesh = data.mesh
        cell_q = element_quality(P, mesh.T, mesh.cells)
        before = summarize_quality(element_quality(mesh.V, mesh.T, mesh.cells))
        rep = rep.with_(quality={"before": before, "after": summarize_quality(cell_q)})
    timing = {"rhs_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1), "check_ms": out.check_ms,
              "report_ms": out.report_ms, "safe_fraction_ms": out.safe_fraction_ms,
              "total_ms": 1e3 * (time.perf_counter() - t0)}
    finite = rep.finite and all_finite(rep.max_displacement, rep.constraint_residual_max,
                                       rep.min_scaled_jacobian or 0.0)
    rep = rep.with_(timings={"setup": data.setup_timings, "update": timing}, finite=bool(finite))
    doc = rep.to_dict()
    if data.spec.conflicts == "reject" and rep.conflicting_constraints:
        raise ConstraintError(f"the move makes {len(rep.conflicting_constraints)} hard constraints conflict "
                              f"(first: {entry_text(rep.conflicting_constraints[0])}); SPEC.conflicts is 'reject'",
                              code="conflicting_constraints", report=doc,
                              **conflict_details(rep.conflicting_constraints, data.constraints.sel_ids))
    if policy == "reject" and rep.inverted_elements > 0:
        raise InversionError(f"the move inverts {rep.inverted_elements} elements (first "
                             f"{format_ids(rep.inverted_ids)}); policy 'reject' returns no result", doc)
    return DeformResult(P, doc, out.move, cell_q, rep)
