"""The public facade: ``Deformer(mesh, spec)`` precomputes, ``.solve(move)`` updates.

A thin object over :func:`~solver.deform.precompute.deform_precompute` (the
frozen :class:`~solver.deform.precompute.DeformData`) and the pure functions
of :mod:`solver.deform.solve`, :mod:`solver.deform.policy` and
:mod:`solver.deform.update`. The method is Masuda & Ogawa, eq. (4.1):
boundary vertices keep their rotated mean curvature normals (eq. 3.1-3.2),
interior vertices their mean value coordinates weighted by ``1/S_i`` (eq.
2.5), fixed and handle vertices are hard constraints (eq. 2.6, 3.3),
rotations are propagated quaternion logarithms (eq. 3.5-3.9; ECLS eq. 22-27).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from ..constraints.move import ResolvedMove, parse_move, scaled_move
from ..constraints.spec import ResolvedSpec, parse_spec
from ..linalg.threads import solving
from ..mesh import Mesh
from ..options import SolveOptions, using
from ..validity.quality import element_quality, summarize_quality
from ..validity.safe_fraction import SAFE_TOL
from .policy import move_safe_fraction
from .positions import InteriorBasis
from .precompute import DeformData, deform_precompute

if TYPE_CHECKING:
    from ..documents.move import Move as MoveDocument
from .solve import (
    BoundaryStage,
    Solved,
    complete,
    interior_basis,
    solve_boundary,
    solve_positions,
    solve_positions_many,
)
from .update import DeformResult, check_options, update

__all__ = ["Deformer", "DeformResult", "precompute"]

F = TypeVar("F", bound=Callable[..., Any])


def _solves(method: F) -> F:
    """Run a :class:`Deformer` method as one solve, under the options it was made with.

    Its threads are chosen when it starts, from the cores free then, within the options' ``threads``
    (:func:`solver.linalg.threads.solving`).
    """
    @functools.wraps(method)
    def run(self: Deformer, *args: Any, **kwargs: Any) -> Any:
        with using(self.data.options), solving():
            return method(self, *args, **kwargs)

    return run  # type: ignore[return-value]


class Deformer:
    """Precomputed deformation of one mesh under one SPEC; never mutated, safe for concurrent solves.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec or dict
    progress : callable, optional
        ``progress(stage, fraction)`` as set-up advances (:func:`~solver.deform.precompute.deform_precompute`).
    options : SolveOptions, optional
        Backend, precision, threads, sweeps and column basis (default: those in effect,
        :func:`solver.options.current`; :meth:`SolveOptions.reference() <solver.options.SolveOptions.reference>`
        is the plain path). The SPEC's ``solve_options`` replace what they name.

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

    def __init__(self, mesh: Mesh, spec: ResolvedSpec | dict[str, Any],
                 progress: Callable[[str, float], None] | None = None, options: SolveOptions | None = None) -> None:
        resolved = spec if isinstance(spec, ResolvedSpec) else parse_spec(spec)
        self.data: DeformData = deform_precompute(mesh, resolved, progress, options)
        cs = self.data.constraints
        self.mesh, self.spec, self.handle_names = mesh, self.data.spec, cs.handle_names
        self.setup_timings, self.factorizations = self.data.setup_timings, self.data.factorizations
        self.rest_constraints, self.solve_mode = cs.rest_constraints, cs.mode
        #: Each edit's dimension at rest, as the set-up measured it: ``{"kind", "name", "parameter",
        #: "rest"}`` (a radius, a distance, or an angle in degrees), for the edits that have one.
        self.edit_dimensions: list[dict[str, Any]] = [
            {"kind": e.kind, "name": e.name, "parameter": e.parameter, "rest": e.dimension}
            for e in cs.edits if e.dimension is not None]

    @property
    def nbytes(self) -> int:
        """Memory held by the factors, operators and rotation basis, in bytes."""
        return self.data.nbytes

    def parse_move(self, move: ResolvedMove | MoveDocument | dict[str, Any]) -> ResolvedMove:
        """Parse a MOVE document (a dict, or its validated model) against this SPEC's names and the mesh's extent.

        The edits' values are checked against their resolved edits too (:meth:`Edit.check
        <solver.constraints.edits.Edit.check>`: a radius that stays positive, twist angles within range,
        control points of the lattice).
        """
        if isinstance(move, ResolvedMove):
            return move
        mv = parse_move(move, self.handle_names, self.spec.names, self.data.constraints.bounds)
        for e in self.data.constraints.edits:
            value = mv.edit(e.kind, e.name)
            if value is not None:
                e.check(value, f"MOVE.{e.kind}.{e.name}")
        return mv

    @_solves
    def solve_positions(self, move: ResolvedMove | dict[str, Any]) -> Solved:
        """Positions of a MOVE, without check or policy (:func:`~solver.deform.solve.solve_positions`)."""
        return solve_positions(self.data, self.parse_move(move))

    @_solves
    def solve_boundary(self, move: ResolvedMove | dict[str, Any]) -> BoundaryStage:
        """The boundary positions of a MOVE first (:func:`~solver.deform.solve.solve_boundary`).

        Pass the stage to :meth:`solve` for the rest.
        """
        return solve_boundary(self.data, self.parse_move(move))

    def scaled_move(self, move: ResolvedMove | dict[str, Any], f: float) -> ResolvedMove:
        """The MOVE scaled by ``f`` in [0, 1] (:func:`~solver.constraints.move.scaled_move`)."""
        return scaled_move(self.parse_move(move), f, self.data.constraints.rest)

    @_solves
    def safe_fraction(self, move: ResolvedMove | dict[str, Any], tol: float = SAFE_TOL,
                      inverts: bool | None = None) -> tuple[float, int]:
        """Largest fraction of a MOVE that inverts no element, and the solves used (bisection)."""
        return move_safe_fraction(self.data, self.parse_move(move), tol, inverts)

    def quality_before(self) -> dict[str, Any]:
        """Summary of every quality metric of the rest mesh."""
        return summarize_quality(element_quality(self.mesh.V, self.mesh.T, self.mesh.cells))

    @_solves
    def solve(self, move: ResolvedMove | dict[str, Any] | BoundaryStage, inversion: str | None = None,
              quality: str = "basic", repair: bool | None = None) -> DeformResult:
        """Deform for one MOVE (or complete a :meth:`solve_boundary` stage) by back-substitution only.

        Parameters
        ----------
        move : ResolvedMove, dict or BoundaryStage
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
        policy = inversion or self.spec.inversion
        check_options(policy, quality)
        if isinstance(move, BoundaryStage):
            mv, t1 = move.move, time.perf_counter()
            solved = complete(self.data, move)
        else:
            mv = self.parse_move(move)
            t1 = time.perf_counter()
            solved = solve_positions(self.data, mv)
        t2 = time.perf_counter()
        return update(self.data, mv, solved, policy, quality, self.spec.repair if repair is None else repair,
                      (t0, t1, t2))

    @_solves
    def solve_many(self, moves: list[ResolvedMove | dict[str, Any]], inversion: str | None = None,
                   quality: str = "basic", repair: bool | None = None,
                   basis: InteriorBasis | None = None) -> list[DeformResult]:
        """:meth:`solve` for several MOVEs, stacked into one multi-column back-substitution per factor.

        Each REPORT's ``solve_ms`` is its share of the stacked solve. Results
        equal separate :meth:`solve` calls to round-off. ``basis``
        (:meth:`interior_basis` of other MOVEs of the same family) is what the
        interior's stacked solve projects on before back-substituting the rest.
        """
        t0 = time.perf_counter()
        policy = inversion or self.spec.inversion
        check_options(policy, quality)
        mvs = [self.parse_move(m) for m in moves]
        t1 = time.perf_counter()
        solved = solve_positions_many(self.data, mvs, basis)
        t2 = time.perf_counter()
        k = max(len(mvs), 1)
        share = (t0, t0 + (t1 - t0) / k, t0 + (t2 - t0) / k)
        rep = self.spec.repair if repair is None else repair
        return [update(self.data, mv, s, policy, quality, rep, share) for mv, s in zip(mvs, solved, strict=True)]

    @_solves
    def interior_basis(self, moves: Sequence[ResolvedMove | dict[str, Any]]) -> InteriorBasis | None:
        """The interior column basis of ``moves``' boundary displacements, for :meth:`solve_many` of their family.

        None where stacked solves use none (a double-precision or small interior
        system, fewer than three MOVEs, or directions that would not pay).
        """
        return interior_basis(self.data, [self.parse_move(m) for m in moves])


def precompute(mesh: Mesh, spec: ResolvedSpec | dict[str, Any], options: SolveOptions | None = None) -> Deformer:
    """Assemble and factor the deformation of ``mesh`` under ``spec``; call ``.solve(move)`` per update.

    ``options`` (:class:`~solver.options.SolveOptions`) choose the backend, the
    supernodal sweeps and the column basis; default: those in effect.
    """
    return Deformer(mesh, spec, options=options)
