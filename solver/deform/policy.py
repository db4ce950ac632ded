"""The inversion policy of an update: repair, safe fraction, clamp, reject.

``warn``
    Solve and report; the REPORT has ``safe_fraction`` when elements inverted.
``clamp``
    An inverting MOVE is scaled by its safe fraction (the largest fraction
    that inverts nothing, found by bisection on back-substitutions) and the
    REPORT says so (``clamped``, ``applied_fraction``, ``inverted_elements_unclamped``).
``reject``
    An inverting MOVE raises :class:`~solver.errors.InversionError` with its REPORT.

Repair (``SPEC.repair``) runs first: inverted elements are untangled by
moving free interior vertices near them (:func:`~solver.validity.repair.repair_inverted`);
a repair that does not reduce the inverted count is discarded.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from ..constraints.move import ResolvedMove, scaled_move
from ..ops.elements import check_tets
from ..validity.repair import repair_inverted
from ..validity.safe_fraction import SAFE_TOL, safe_fraction
from .precompute import DeformData
from .report import Report
from .solve import Solved, check_positions, evaluate, solve_positions

__all__ = ["Outcome", "apply_policy", "move_safe_fraction", "INVERSION_POLICIES"]

INVERSION_POLICIES = ("warn", "reject", "clamp")


@dataclass(frozen=True, eq=False)
class Outcome:
    """An update after its policy: the positions, the REPORT (no timings), the MOVE applied."""

    solved: Solved
    report: Report
    move: ResolvedMove
    check_ms: float
    report_ms: float
    safe_fraction_ms: float


def move_safe_fraction(data: DeformData, mv: ResolvedMove, tol: float = SAFE_TOL,
                       inverts: bool | None = None) -> tuple[float, int]:
    """Largest fraction of ``mv`` that inverts no element (:func:`~solver.validity.safe_fraction.safe_fraction`).

    ``f = 0`` (the rest shape) is valid because inputs with inverted elements
    are refused; each step is one back-substitution and one check.
    """
    if data.check is None:
        return 1.0, 0

    def valid_at(f: float) -> bool:
        mv_f = mv if f == 1.0 else scaled_move(mv, f, data.constraints.rest)
        c = check_positions(data, solve_positions(data, mv_f))
        return c is None or c.count == 0

    return safe_fraction(valid_at, tol, None if inverts is None else not inverts)


def apply_policy(data: DeformData, solved: Solved, mv: ResolvedMove, policy: str, repair: bool) -> Outcome:
    """Evaluate one solve and apply repair and the inversion policy.

    Parameters
    ----------
    data : DeformData
    solved : Solved
        The positions of ``mv``.
    mv : ResolvedMove
    policy : {"warn", "reject", "clamp"}
        ``reject`` is applied by the caller, which raises with the REPORT.
    repair : bool

    Returns
    -------
    Outcome
    """
    t0 = time.perf_counter()
    check = check_positions(data, solved)
    tc = time.perf_counter()
    report = evaluate(data, solved, mv, check)
    repair_rep = None
    if repair and report.inverted_elements > 0 and not data.mesh.is_surface:
        mesh = data.mesh
        rr = repair_inverted(mesh.V, solved.P, check_tets(mesh.T, mesh.cells), data.constraints.movable)
        repair_rep = rr.report
        if rr.report["accepted"]:
            solved = solved.with_positions(rr.V)
            report = evaluate(data, solved, mv)
    t1 = time.perf_counter()
    safe_ms = 0.0
    if report.inverted_elements > 0:
        f, steps = move_safe_fraction(data, mv, inverts=True)
        report = report.with_(safe_fraction=f, safe_fraction_solves=steps)
        if policy == "clamp":
            unclamped = report.inverted_elements
            mv = scaled_move(mv, f, data.constraints.rest)
            solved = solve_positions(data, mv)
            report = evaluate(data, solved, mv).with_(
                safe_fraction=f, safe_fraction_solves=steps, clamped=True, applied_fraction=f,
                inverted_elements_unclamped=unclamped)
        safe_ms = 1e3 * (time.perf_counter() - t1)
    if repair_rep is not None:
        report = report.with_(repair=repair_rep)
    return Outcome(solved, report, mv, 1e3 * (tc - t0), 1e3 * (t1 - tc), safe_ms)
