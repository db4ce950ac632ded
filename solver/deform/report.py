"""The REPORT of one update: validity, constraint residuals, redundancy and conflicts, timings.

:class:`Report` is the frozen dataclass of :mod:`solver.documents.report_record`
(the REPORT's one definition, each field described there);
:meth:`Report.to_dict` gives the JSON document the CLI writes and the service
returns. :func:`constraint_report` measures the hard constraints of a solve:
the residual is a distance (metres, not a per-coordinate maximum) over every
constrained node, mid-side nodes included, and every hard row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..constraints.assembly import describe
from ..constraints.move import ResolvedMove
from ..constraints.rows import REPORT_IDS
from ..documents.report_record import Report
from ..validity.check import CheckResult
from .constraint_set import CONFLICT_TOL, ConstraintSet
from .rotation_field import RotationField

__all__ = ["Report", "ConstraintReport", "constraint_report", "element_report", "all_finite"]


@dataclass(frozen=True)
class ConstraintReport:
    """Hard-constraint part of a REPORT.

    Attributes
    ----------
    residual_max : float
        Largest distance of a fixed or handle node (corner or mid-side) from
        its target, or of a kept hard row from its target (Euclidean over x, y, z).
    rows : dict
        ``{"rows", "dropped"}``: kept and dropped rows of both systems.
    redundant, conflicting : list of dict
        Dropped rows that hold anyway, and those that do not (with residual).
    """

    residual_max: float
    rows: dict[str, int]
    redundant: list[dict[str, Any]]
    conflicting: list[dict[str, Any]]


def all_finite(*values: Any) -> bool:
    """Whether every number in nested values (arrays, dicts, lists) is finite."""
    for v in values:
        if isinstance(v, np.ndarray):
            if v.dtype.kind in "fc" and not np.isfinite(v).all():
                return False
        elif isinstance(v, dict):
            if not all_finite(*v.values()):
                return False
        elif isinstance(v, (list, tuple)):
            if not all_finite(*v):
                return False
        elif isinstance(v, float) and not math.isfinite(v):
            return False
    return True


def _distance_residuals(cs: ConstraintSet, res: np.ndarray) -> np.ndarray:
    """Per-row residuals of the position system as distances: x, y, z rows of one replicated row combined."""
    asm = cs.pasm
    if asm is None or not asm.vector or not res.size:
        return res
    expanded = asm.coord >= 0
    if not expanded.any():
        return res
    out = res.copy()
    key = asm.block * (int(asm.local.max()) + 1 if asm.local.size else 1) + asm.local
    _, inv = np.unique(key[expanded], return_inverse=True)
    sq = np.zeros(inv.max() + 1)
    np.add.at(sq, inv, res[expanded] ** 2)
    out[expanded] = np.sqrt(sq)[inv]
    return out


def constraint_report(cs: ConstraintSet, system: Any, rotation: RotationField, P: np.ndarray, U: np.ndarray,
                      d: np.ndarray | None, pinned: np.ndarray, pinned_at: np.ndarray,
                      move: ResolvedMove) -> ConstraintReport:
    """Residuals, redundant and conflicting constraints of a solve (ECLS §5).

    Parameters
    ----------
    cs : ConstraintSet
    system : ConstrainedSolver or None
        The position system.
    rotation : RotationField
    P : (n, 3) float array
        Positions.
    U : (k, 3) float array
        Targets of the fixed and handle corner nodes.
    d : array or None
        Targets of the position system's hard rows.
    pinned, pinned_at : (p,) int array, (p, 3) float array
        Fixed and handle mid-side nodes and their targets.
    move : ResolvedMove

    Returns
    -------
    ConstraintReport
    """
    res_max = float(np.linalg.norm(P[cs.constrained] - U, axis=1).max()) if U.size else 0.0
    if pinned.size:
        res_max = max(res_max, float(np.linalg.norm(P[pinned] - pinned_at, axis=1).max()))
    redundant: list[dict[str, Any]] = []
    conflicting: list[dict[str, Any]] = []
    rows = {"rows": 0, "dropped": 0}
    if system is not None and d is not None and cs.pasm is not None:
        x = P[cs.unknowns].reshape(-1, 1) if cs.vector else P[cs.unknowns]
        res = _distance_residuals(cs, system.residuals(x, d))
        kept = system.kept
        rows["rows"] += int(kept.size)
        if kept.any():
            res_max = max(res_max, float(res[kept].max()))
        drop = np.flatnonzero(~kept)
        rows["dropped"] += int(drop.size)
        bad = res[drop] > cs.conflict_tol
        redundant += describe(cs.blocks, cs.pasm, drop[~bad], "positions")
        conflicting += describe(cs.blocks, cs.pasm, drop[bad], "positions", res[drop[bad]])
    if rotation.system is not None and cs.rasm is not None:
        rres = np.linalg.norm(rotation.unit_residuals @ rotation.unit_vector(move), axis=1) \
            if rotation.unit_residuals.shape[0] else np.zeros(0)
        kept = rotation.system.kept
        rows["rows"] += int(kept.size)
        drop = np.flatnonzero(~kept)
        rows["dropped"] += int(drop.size)
        bad = rres[drop] > CONFLICT_TOL
        redundant += describe(cs.rblocks, cs.rasm, drop[~bad], "rotations")
        conflicting += describe(cs.rblocks, cs.rasm, drop[bad], "rotations", rres[drop[bad]])
    return ConstraintReport(res_max, rows, redundant, conflicting)


def element_report(check: CheckResult, valid_rest: np.ndarray | None) -> dict[str, Any]:
    """The element part of a REPORT (counts, first ids, scaled Jacobians; quadratic ratios)."""
    out: dict[str, Any] = {
        "inverted_elements": check.count,
        "inverted_ids": check.ids[:REPORT_IDS].tolist(),
        "degenerate_elements": check.degenerate,
        "min_scaled_jacobian": check.min_sj,
        "p01_scaled_jacobian": check.p01_sj,
    }
    dj = check.node_jacobians
    if dj is not None and valid_rest is not None:
        ratio = dj.min(axis=1) / np.maximum(np.abs(dj).max(axis=1), 1e-300)
        out["element_order"] = 2
        out["min_jacobian_ratio"] = float(ratio[valid_rest].min()) if valid_rest.any() else float(ratio.min())
        out["invalid_at_rest_elements"] = int((~valid_rest).sum())
    return out
