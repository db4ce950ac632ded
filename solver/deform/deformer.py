"""The public facade: ``Deformer(mesh, spec)`` precomputes, ``.solve(move)`` updates.

A thin object over :func:`~solver.deform.precompute.deform_precompute` (the
frozen :class:`~solver.deform.precompute.DeformData`) and the pure functions
of :mod:`solver.deform.solve` and :mod:`solver.deform.policy`. The method is
Masuda & Ogawa, eq. (4.1): boundary vertices keep their rotated mean
curvature normals (eq. 3.1-3.2), interior vertices their mean value
coordinates weighted by ``1/S_i`` (eq. 2.5), fixed and handle vertices are
hard constraints (eq. 2.6, 3.3), rotations are propagated quaternion
logarithms (eq. 3.5-3.9; ECLS eq. 22-27).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..constraints.move import Move, parse_move, scaled_move
from ..constraints.spec import Spec, parse_spec
from ..errors import ConstraintError, InversionError, SpecError, format_ids
from ..mesh import Mesh
from ..validity.quality import element_quality, summarize_quality
from ..validity.safe_fraction import SAFE_TOL
from .constraint_set import entry_text
from .policy import INVERSION_POLICIES, apply_policy, move_safe_fraction
from .precompute import DeformData, deform_precompute
from .report import Report, all_finite
from .solve import Solved, solve_positions

__all__ = ["Deformer", "DeformResult", "precompute"]


@dataclass(frozen=True, eq=False)
class DeformResult:
    """Result of one update.

    Attributes
    ----------
    V : (n, 3) float64 array
        Deformed positions in file order (unreferenced vertices unchanged).
    report : dict
        The REPORT document (``report_data.to_dict()``).
    move : Move
        The MOVE that was applied (the scaled one when the policy clamped it).
    cell_quality : dict of str to (m,) array, optional
        Per-element metrics (``quality="full"``), see :func:`solver.validity.quality.element_quality`.
    report_data : Report, optional
        The REPORT as a dataclass.
    """

    V: np.ndarray
    report: dict[str, Any]
    move: Move | None = None
    cell_quality: dict[str, np.ndarray] | None = None
    report_data: Report | None = None


class Deformer:
    """Precomputed deformation of one mesh under one SPEC; never mutated, safe for concurrent solves.

    Parameters
    ----------
    mesh : Mesh
    spec : Spec or dict
    progress : callable, optional
        ``progress(stage, fraction)`` as set-up advances (:func:`~solver.deform.precompute.deform_precompute`).

    Raises
    ------
    SpecError, ConstraintError, FactorizationError

    Examples
    --------
    >>> from solver.mesh import mesh_from_arrays
    >>> from solver.testing import cube_mesh
    >>> mesh = mesh_from_arrays(*cube_mesh(3))
    >>> d = Deformer(mesh, {"selections": {"bottom": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
    ...                                    "top": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
    ...                     "fixed": ["bottom"], "handles": {"top": "top"}})
    >>> r = d.solve({"handles": {"top": {"translation": [0.1, 0, 0]}}})
    >>> r.report["inverted_elements"], round(float(r.V[:, 0].max()), 6)
    (0, 1.1)
    """

    def __init__(self, mesh: Mesh, spec: Spec | dict[str, Any],
                 progress: Callable[[str, float], None] | None = None) -> None:
        self.data: DeformData = deform_precompute(mesh, spec if isinstance(spec, Spec) else parse_spec(spec), progress)
        cs = self.data.constraints
        self.mesh, self.spec, self.handle_names = mesh, self.data.spec, cs.handle_names
        self.setup_timings, self.factorizations = self.data.setup_timings, self.data.factorizations
        self.rest_constraints, self.solve_mode = cs.rest_constraints, cs.mode

    @property
    def nbytes(self) -> int:
        """Memory held by the factors, operators and rotation basis, in bytes."""
        return self.data.nbytes

    def parse_move(self, move: Move | dict[str, Any]) -> Move:
        """Parse a MOVE document against this SPEC's names and the mesh's extent."""
        if isinstance(move, Move):
            return move
        return parse_move(move, self.handle_names, self.spec.names, self.data.constraints.bounds)

    def solve_positions(self, move: Move | dict[str, Any]) -> Solved:
        """Positions of a MOVE, without check or policy (:func:`~solver.deform.solve.solve_positions`)."""
        return solve_positions(self.data, self.parse_move(move))

    def scaled_move(self, move: Move | dict[str, Any], f: float) -> Move:
        """The MOVE scaled by ``f`` in [0, 1] (:func:`~solver.constraints.move.scaled_move`)."""
        return scaled_move(self.parse_move(move), f, self.data.constraints.rest)

    def safe_fraction(self, move: Move | dict[str, Any], tol: float = SAFE_TOL,
                      inverts: bool | None = None) -> tuple[float, int]:
        """Largest fraction of a MOVE that inverts no element, and the solves used (bisection)."""
        return move_safe_fraction(self.data, self.parse_move(move), tol, inverts)

    def quality_before(self) -> dict[str, Any]:
        """Summary of every quality metric of the rest mesh."""
        return summarize_quality(element_quality(self.mesh.V, self.mesh.T, self.mesh.cells))

    def solve(self, move: Move | dict[str, Any], inversion: str | None = None, quality: str = "basic",
              repair: bool | None = None) -> DeformResult:
        """Deform for one MOVE by back-substitution only.

        Parameters
        ----------
        move : Move or dict
        inversion : {"warn", "reject", "clamp"}, optional
            Overrides the SPEC's policy (:mod:`solver.deform.policy`).
        quality : {"basic", "full"}
            ``"full"`` adds ``report["quality"] = {"before", "after"}`` and the
            per-element arrays in ``DeformResult.cell_quality``.
        repair : bool, optional
            Overrides ``SPEC.repair``.

        Returns
        -------
        DeformResult

        Raises
        ------
        SpecError
            Malformed MOVE, unknown names, bad policy or quality.
        ConstraintError
            The MOVE makes hard constraints conflict and ``SPEC.conflicts`` is ``"reject"``.
        InversionError
            Elements were inverted and the policy is ``"reject"``.
        """
        t0 = time.perf_counter()
        mv = self.parse_move(move)
        policy = inversion or self.spec.inversion
        if policy not in INVERSION_POLICIES:
            raise SpecError(f"inversion policy must be one of {list(INVERSION_POLICIES)}, got {policy!r}",
                            field="inversion")
        if quality not in ("basic", "full"):
            raise SpecError(f"quality must be 'basic' or 'full', got {quality!r}", field="quality")
        n0 = self.data.factorizations
        t1 = time.perf_counter()
        solved = solve_positions(self.data, mv)
        t2 = time.perf_counter()
        out = apply_policy(self.data, solved, mv, policy, self.spec.repair if repair is None else repair)
        rep, P = out.report, out.solved.P
        cell_q = None
        if quality == "full" and self.data.check is not None:
            cell_q = element_quality(P, self.mesh.T, self.mesh.cells)
            rep = rep.with_(quality={"before": self.quality_before(), "after": summarize_quality(cell_q)})
        update = {"rhs_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1), "check_ms": out.check_ms,
                  "safe_fraction_ms": out.safe_fraction_ms, "total_ms": 1e3 * (time.perf_counter() - t0)}
        rep = rep.with_(timings={"setup": self.setup_timings, "update": update},
                        refactorized=self.data.factorizations != n0)
        rep = rep.with_(finite=bool(rep.finite and all_finite(rep.max_displacement, rep.constraint_residual_max,
                                                              rep.min_scaled_jacobian or 0.0)))
        doc = rep.to_dict()
        if self.spec.conflicts == "reject" and rep.conflicting_constraints:
            raise ConstraintError(f"the move makes {len(rep.conflicting_constraints)} hard constraints conflict "
                                  f"(first: {entry_text(rep.conflicting_constraints[0])}); SPEC.conflicts is "
                                  "'reject'", code="conflicting_constraints", report=doc)
        if policy == "reject" and rep.inverted_elements > 0:
            raise InversionError(f"the move inverts {rep.inverted_elements} elements (first "
                                 f"{format_ids(rep.inverted_ids)}); policy 'reject' returns no result", doc)
        return DeformResult(P, doc, out.move, cell_q, rep)


def precompute(mesh: Mesh, spec: Spec | dict[str, Any]) -> Deformer:
    """Assemble and factor the deformation of ``mesh`` under ``spec``; call ``.solve(move)`` per update."""
    return Deformer(mesh, spec)
