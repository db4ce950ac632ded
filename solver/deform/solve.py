"""Solve: a MOVE through the precompute, by back-substitution only (libigl's ``*_solve``).

Every function here is pure: it reads a :class:`~solver.deform.precompute.DeformData`
and a parsed MOVE and returns values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constraints.move import ResolvedMove
from ..constraints.rows import REPORT_IDS
from ..linalg import factorization as fz
from ..ops.displacement import displacement_maxima
from ..ops.unique import union
from ..options import using
from ..validity.check import CheckResult, SurfaceCheck
from ..validity.midside import Placement
from .positions import InteriorBasis, PositionSolve
from .precompute import DeformData
from .report import Report, constraint_report, element_report
from .rhs import RightHandSides

__all__ = ["Solved", "BoundaryStage", "solve_positions", "solve_positions_many", "interior_basis", "solve_boundary",
           "complete", "check_positions", "evaluate"]


@dataclass(frozen=True, eq=False)
class Solved:
    """The positions of one MOVE and what they were solved against.

    Attributes
    ----------
    P : (n, 3) float array
        Positions in file order (unreferenced vertices at rest).
    U : (k, 3) float array
        Targets of the fixed and handle corner nodes.
    d : array or None
        Targets of the position system's hard rows.
    pinned_at : (p, 3) float array
        Targets of the fixed and handle mid-side nodes (``DeformData.pinned_mid``).
    placement : Placement or None
        Quadratic meshes: the mid-side placement (its node Jacobians).
    interior_residual : float or None
        Mixed precision: the interior's relative mean-value residual.
    interior_refined : bool
    """

    P: np.ndarray
    U: np.ndarray
    d: np.ndarray | None
    pinned_at: np.ndarray
    placement: Placement | None = None
    interior_residual: float | None = None
    interior_refined: bool = False

    def with_positions(self, P: np.ndarray) -> Solved:
        """The same solve with other positions (after repair)."""
        return Solved(P, self.U, self.d, self.pinned_at, None, self.interior_residual, self.interior_refined)


def solve_positions(data: DeformData, move: ResolvedMove) -> Solved:
    """Positions for a parsed MOVE (eq. 4.2/4.3 by back-substitution; mid-side nodes placed after).

    Fixed and handle mid-side nodes are set exactly to their targets; the
    others follow their edges (:class:`~solver.validity.midside.MidsideNodes`).
    """
    rhs = data.rhs(move)
    ps = data.positions.solve(data.mesh.V, data.constraints.constrained, rhs)
    return finish(data, ps, rhs, move)


def solve_positions_many(data: DeformData, moves: list[ResolvedMove],
                         basis: InteriorBasis | None = None) -> list[Solved]:
    """:func:`solve_positions` for several MOVEs: their right-hand sides stacked, one back-substitution per factor.

    Each result equals :func:`solve_positions` of its MOVE to round-off (a
    multi-column solve sums in another order). ``basis``: the interior's column
    basis to solve through (:func:`interior_basis`).
    """
    rhss = [data.rhs(mv) for mv in moves]
    solves = data.positions.solve_many(data.mesh.V, data.constraints.constrained, rhss, basis)
    return [finish(data, ps, rhs, mv) for ps, rhs, mv in zip(solves, rhss, moves, strict=True)]


def interior_basis(data: DeformData, moves: list[ResolvedMove]) -> InteriorBasis | None:
    """The interior column basis of the boundary displacements of ``moves`` (None where stacked solves use none)."""
    if not data.positions.uses_basis(len(moves)):
        return None  # nothing solved
    rhss = [data.rhs(mv) for mv in moves]
    return data.positions.interior_basis(data.positions.boundary_many(data.mesh.V, data.constraints.constrained, rhss))


@dataclass(frozen=True, eq=False)
class BoundaryStage:
    """The first stage of a split solve: boundary positions, interior still at rest.

    Attributes
    ----------
    move : ResolvedMove
    rhs : RightHandSides
    P : (n, 3) float array
        Positions whose fixed, handle and boundary vertices are final.
    ids : (b,) int array
        The vertices that are final (boundary and constrained ones).
    """

    move: ResolvedMove
    rhs: RightHandSides
    P: np.ndarray
    ids: np.ndarray


def solve_boundary(data: DeformData, move: ResolvedMove) -> BoundaryStage:
    """Boundary positions of a MOVE (the split solve's boundary system only; joint solves everything).

    For interactive editing: the boundary is what a viewer draws; the
    interior (the larger back-substitution) follows in :func:`complete`.
    """
    rhs = data.rhs(move)
    P = data.positions.boundary(data.mesh.V, data.constraints.constrained, rhs)
    ids = union(data.constraints.bidx, data.constraints.constrained)
    return BoundaryStage(move, rhs, P, ids)


def complete(data: DeformData, stage: BoundaryStage) -> Solved:
    """The rest of a solve after :func:`solve_boundary`: interior and mid-side nodes."""
    return finish(data, data.positions.interior_solve(stage.P), stage.rhs, stage.move)


def finish(data: DeformData, ps: PositionSolve, rhs: RightHandSides, move: ResolvedMove) -> Solved:
    """Mid-side placement (quadratic meshes) after the corner positions of a solve."""
    P = ps.P
    if data.spec.method == "penalty" and data.constraints.corr.mapped:
        P = _images_set(P, data.constraints.corr.mapped, data.constraints.constrained)
    if data.constraints.mirrors:  # interior mirror pairs exactly each other's image, whatever the precision
        P = P.copy()
        for mi in data.constraints.mirrors:
            mi.apply(P)
    pinned_at = data.pinned_targets(move)
    placement = None
    if data.midside is not None and data.check is not None:
        placement = data.midside.place(P, data.check.valid_rest, data.pinned_mid, pinned_at)
        P = placement.P
        mapped = [e.midside for e in data.constraints.corr.mapped if e.midside is not None and e.midside.slaves.size]
        if mapped:  # mid-side nodes of a mirrored or cyclic face: the image of the master side, exactly
            P = P.copy()
            for m in mapped:
                P[m.slaves] = np.einsum("sk,skj->sj", m.weights, P[m.masters]) @ m.A.T + m.t
            placement = Placement(P, None, placement.relaxed)
    return Solved(P, rhs.U, rhs.d, pinned_at, placement, ps.interior_residual, ps.refined)


def _backend(data: DeformData) -> str:
    """The symmetric backend the precompute's options resolve to (whatever is in effect at solve time)."""
    with using(data.positions.options):
        return fz.backend()


def _images_set(P: np.ndarray, mapped: list, constrained: np.ndarray) -> np.ndarray:
    """Free corner slaves of mirror and cyclic entries set to the images of their master points, exactly.

    The penalty method (eq. 3.8) meets ``p_b = A p_a + t`` only to about
    ``1 / beta``; a symmetry is a property of the part, not a soft target, so
    its free slaves are set exactly after the solve. A slave that is also fixed
    or in a handle keeps the penalty's compromise (and its residual is reported).
    """
    P = P.copy()
    held = np.zeros(len(P), bool)
    held[constrained] = True
    for e in mapped:  # in SPEC order: an entry whose masters are another's slaves sees them already set
        m = e.matching
        free = ~held[m.slaves]
        if free.any():
            pts = np.einsum("sk,skj->sj", m.weights[free], P[m.masters[free]])
            P[m.slaves[free]] = pts @ m.A.T + m.t
    return P


def check_positions(data: DeformData, solved: Solved) -> CheckResult | None:
    """The element check at ``solved.P`` (None for triangle surfaces)."""
    if data.check is None:
        return None
    return data.check.check(solved.P, solved.placement)


def evaluate(data: DeformData, solved: Solved, move: ResolvedMove, check: CheckResult | None = None) -> Report:
    """The REPORT of one solve (no policy, no timings).

    Parameters
    ----------
    data : DeformData
    solved : Solved
    move : ResolvedMove
    check : CheckResult, optional
        Reused when given, else computed.

    Returns
    -------
    Report
    """
    cs = data.constraints
    cons = constraint_report(cs, data.positions.system, data.rotation, solved.P, solved.U, solved.d,
                             data.pinned_mid, solved.pinned_at, move)
    if check is None:
        check = check_positions(data, solved)
    el = element_report(check, data.check.valid_rest) if check is not None and data.check is not None else {
        "inverted_elements": 0, "inverted_ids": [], "degenerate_elements": 0,
        "min_scaled_jacobian": None, "p01_scaled_jacobian": None}
    before = data.check.sj_before if data.check is not None else (None, None)
    max_disp, max_handle, max_free, finite = displacement_maxima(solved.P, data.mesh.V,
                                                                 cs.owner if cs.roles is None else cs.roles)
    flat = data.check.degenerate_at_rest if data.check is not None else np.zeros(0, np.int64)
    targets = None
    if cs.corr.targets:
        targets = {}
        for t in cs.corr.targets:
            nodes = np.r_[t.ids, t.mid_ids]
            dist = t.surface.closest(solved.P[nodes]).dist  # re-projected: how far the solve left them
            targets[t.name] = {"amount": float(move.targets.get(t.name, 0.0)), "nodes": int(nodes.size),
                               "iterations": 1, "max_distance": float(dist.max()),
                               "mean_distance": float(dist.mean())}
    ratio = None
    if isinstance(data.check, SurfaceCheck) and data.check.closed.any():
        ratio = float(np.nanmin(data.check.volume_ratios(solved.P)))
    relaxed = solved.placement.relaxed if solved.placement is not None else None
    return Report(
        **el, min_scaled_jacobian_before=before[0], p01_scaled_jacobian_before=before[1],
        constraint_residual_max=cons.residual_max,
        constraint_residual_relative=cons.residual_max / cs.diag if cs.diag else 0.0,
        constraint_rows=cons.rows, redundant_constraints=cons.redundant,
        conflicting_constraints=cons.conflicting,
        max_displacement=max_disp, max_handle_displacement=max_handle if cs.handle_names or cs.edits else None,
        max_free_displacement=max_free,
        solve_method=data.spec.method, solve_mode=data.positions.mode, refine_steps=data.positions.refine_steps,
        backend=_backend(data), lu_backend=data.positions.lu_backend,
        finite=finite, midside_relaxed=relaxed,
        interior_precision=data.positions.interior_precision, mean_value_residual=solved.interior_residual,
        interior_refined=solved.interior_refined if solved.interior_residual is not None else None,
        degenerate_at_rest={"count": int(flat.size), "ids": flat[:REPORT_IDS].tolist()}, enclosed_volume_ratio=ratio,
        targets=targets)
