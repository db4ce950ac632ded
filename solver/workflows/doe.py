"""DOE: every row of a plan morphed through one precompute, blocks of rows in one back-substitution.

:func:`run_doe` turns each plan row into its variant's MOVE
(:func:`~solver.workflows.shapes.variant_move`), validates all of them before
any solve, then solves blocks of rows with
:meth:`~solver.deform.deformer.Deformer.solve_many`: their right-hand sides
stacked into one multi-column back-substitution per factor. Each row's result
is the one :meth:`~solver.deform.deformer.Deformer.solve` (and so ``tetmorph
morph``) gives for the variant's MOVE, to round-off, with the same inversion
policy and REPORT.

For a service: pure function of a deformer, the shapes and a plan, returning
:class:`DoeResult`; results go to an ``output`` callback (:func:`deck_writer`
writes decks), ``progress(done, total)`` after each block, ``cancelled()``
checked before each block.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO, Any, Literal

import numpy as np

from ..deform.deformer import Deformer, DeformResult
from ..deform.positions import InteriorBasis
from ..errors import ConstraintError, SpecError
from ..io import write_mesh
from ..mesh import Mesh
from .plan import Plan, check_block, plan_values
from .shapes import Shapes, variant_move

__all__ = ["Variant", "DoeResult", "run_doe", "doe_basis", "deck_writer", "write_summary", "summary_rows", "BLOCK",
           "SUMMARY_FIELDS"]

#: Rows solved together (one multi-column back-substitution) by default.
BLOCK = 16
#: Summary columns after the row number and the parameters.
SUMMARY_FIELDS = ("inverted", "min_scaled_jacobian", "max_displacement", "constraint_residual_max", "file",
                  "status")

#: ``output(row, result) -> path or None``: stores one variant (``row`` counts from 1).
Output = Callable[[int, DeformResult], str | None]


@dataclass(frozen=True)
class Variant:
    """One plan row's outcome.

    Attributes
    ----------
    row : int
        Plan row, from 1.
    parameters : dict of str to float
        The row's value of every shape.
    status : {"ok", "rejected", "conflict"}
        ``rejected``: the policy is ``reject`` and the variant inverts elements
        (nothing is written); ``conflict``: the variant makes hard constraints
        conflict and ``SPEC.conflicts`` is ``reject``.
    inverted : int or None
    min_scaled_jacobian : float or None
    max_displacement : float or None
    constraint_residual_max : float or None
    file : str or None
        What ``output`` returned (the deck written).
    report : dict
        The full REPORT of the update (or the error document).
    """

    row: int
    parameters: dict[str, float]
    status: str
    inverted: int | None
    min_scaled_jacobian: float | None
    max_displacement: float | None
    constraint_residual_max: float | None
    file: str | None = None
    report: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """The summary row: ``row``, the parameters, then :data:`SUMMARY_FIELDS`."""
        return {"row": self.row, **self.parameters, "inverted": self.inverted,
                "min_scaled_jacobian": self.min_scaled_jacobian, "max_displacement": self.max_displacement,
                "constraint_residual_max": self.constraint_residual_max, "file": self.file, "status": self.status}


@dataclass(frozen=True)
class DoeResult:
    """Outcome of a plan.

    Attributes
    ----------
    shapes : tuple of str
    variants : list of Variant
        One per row solved, in plan order.
    rows : int
        Rows in the plan.
    cancelled : bool
        Whether ``cancelled()`` stopped the run (``variants`` has the rows done).
    block : int
    timings : dict
        ``solve_ms`` (parse, the interior basis, solves, checks, REPORTs),
        ``output_ms`` (the callback: writing decks), ``total_ms``,
        ``per_variant_ms`` (solve only), ``interior_basis_columns`` (directions
        of the first block's interior basis; 0 when stacked solves use none).
    """

    shapes: tuple[str, ...]
    variants: list[Variant]
    rows: int
    cancelled: bool
    block: int
    timings: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible summary (no REPORTs)."""
        return {"shapes": list(self.shapes), "rows": self.rows, "done": len(self.variants),
                "cancelled": self.cancelled, "block": self.block, "timings": self.timings,
                "variants": [v.summary() for v in self.variants]}


def _variant(row: int, params: dict[str, float], res: DeformResult, status: str) -> Variant:
    r = res.report
    return Variant(row, params, status, int(r["inverted_elements"]), r.get("min_scaled_jacobian"),
                   r.get("max_displacement"), r.get("constraint_residual_max"), None, r)


def _solve_block(deformer: Deformer, moves: list[Any], policy: str, quality: str,
                 basis: InteriorBasis | None = None) -> list[DeformResult | ConstraintError]:
    """Results of a block; a block whose stacked solve raises a conflict is solved row by row."""
    try:
        return list(deformer.solve_many(moves, policy, quality, basis=basis))
    except ConstraintError:
        out: list[DeformResult | ConstraintError] = []
        for mv in moves:
            try:
                out.append(deformer.solve(mv, policy, quality))
            except ConstraintError as e:
                out.append(e)
        return out


def doe_basis(deformer: Deformer, shapes: Shapes, plan: Plan, block: int = BLOCK) -> InteriorBasis | None:
    """The interior column basis of the plan's first block, which :func:`run_doe` solves every block through.

    A process that solves only some blocks of a plan (a Ray actor, a service
    batch's block) passes this as ``run_doe(..., basis=)`` to get the decks of
    a whole run bit for bit. None where stacked solves use no basis, or when
    the first block's MOVEs conflict (such blocks are solved row by row).

    Parameters
    ----------
    deformer : Deformer
    shapes : Shapes
    plan : Plan
        The whole plan.
    block : int
        Rows per stacked solve, as given to :func:`run_doe`.

    Returns
    -------
    InteriorBasis or None
    """
    theta = plan_values(plan, shapes)
    first = [variant_move(deformer, shapes, theta[i], plan.where(i)) for i in range(min(block, plan.rows))]
    try:
        return deformer.interior_basis(first)
    except ConstraintError:
        return None


def run_doe(deformer: Deformer, shapes: Shapes, plan: Plan, *, block: int = BLOCK, output: Output | None = None,
            progress: Callable[[int, int], None] | None = None, cancelled: Callable[[], bool] | None = None,
            inversion: str | None = None, quality: str = "basic",
            basis: InteriorBasis | None | Literal["first"] = "first") -> DoeResult:
    """Morph every row of ``plan``.

    Parameters
    ----------
    deformer : Deformer
    shapes : Shapes
        Parsed against ``deformer`` (:func:`~solver.workflows.shapes.parse_shapes`).
    plan : Plan
    block : int
        Rows per stacked solve (>= 1).
    output : callable, optional
        ``output(row, result) -> path or None`` for every variant that is not
        rejected; its return value is the summary's ``file``.
    progress : callable, optional
        ``progress(rows_done, rows_total)`` after each block.
    cancelled : callable, optional
        ``cancelled() -> bool``, asked before each block; True stops the run.
    inversion : {"warn", "reject", "clamp"}, optional
        Overrides the SPEC's policy, as ``morph --inversion``. With ``reject``
        an inverting row is recorded as ``rejected`` and the others go on.
    quality : {"basic", "full"}
    basis : InteriorBasis, None or "first"
        The interior column basis every block's stacked solve projects on
        (:func:`doe_basis`): ``"first"`` builds it from this plan's first block;
        None lets each block use its own columns only.

    Returns
    -------
    DoeResult

    Raises
    ------
    SpecError
        An unknown plan column, a bad policy or block size, or a row whose
        variant is not a valid MOVE (naming the row) -- before anything is solved.
    """
    check_block(block, "invalid_plan")
    policy = inversion or deformer.spec.inversion
    if policy not in ("warn", "reject", "clamp"):
        raise SpecError(f"inversion policy must be one of ['warn', 'reject', 'clamp'], got {policy!r}",
                        field="inversion")
    t0 = time.perf_counter()
    theta = plan_values(plan, shapes)
    moves = [variant_move(deformer, shapes, theta[i], plan.where(i)) for i in range(plan.rows)]
    solve_policy = "warn" if policy == "reject" else policy
    variants: list[Variant] = []
    solve_s = output_s = 0.0
    stopped = False
    if basis == "first":
        t1 = time.perf_counter()
        basis = doe_basis(deformer, shapes, plan, block) if plan.rows > 2 and block > 2 else None
        solve_s += time.perf_counter() - t1
    for start in range(0, plan.rows, block):
        if cancelled is not None and cancelled():
            stopped = True
            break
        t1 = time.perf_counter()
        results = _solve_block(deformer, moves[start:start + block], solve_policy, quality, basis)
        t2 = time.perf_counter()
        solve_s += t2 - t1
        for j, res in enumerate(results):
            i = start + j
            params = {n: float(theta[i, k]) for k, n in enumerate(shapes.names)}
            if isinstance(res, ConstraintError):
                variants.append(Variant(i + 1, params, "conflict", None, None, None, None, None,
                                        {"error": res.to_dict()}))
                continue
            if policy == "reject" and res.report["inverted_elements"] > 0:
                variants.append(_variant(i + 1, params, res, "rejected"))
                continue
            v = _variant(i + 1, params, res, "ok")
            if output is not None:
                t3 = time.perf_counter()
                v = dataclasses.replace(v, file=output(i + 1, res))
                output_s += time.perf_counter() - t3
            variants.append(v)
        if progress is not None:
            progress(len(variants), plan.rows)
    timings = {"solve_ms": 1e3 * solve_s, "output_ms": 1e3 * output_s,
               "interior_basis_columns": float(basis.rank) if isinstance(basis, InteriorBasis) else 0.0,
               "total_ms": 1e3 * (time.perf_counter() - t0),
               "per_variant_ms": 1e3 * solve_s / max(len(variants), 1)}
    return DoeResult(shapes.names, variants, plan.rows, stopped, block, timings)


def deck_writer(mesh: Mesh, pattern: str, file_format: str | None = None, nastran_large: bool = False,
                flatten: bool = False) -> Output:
    """An ``output`` callback writing each variant with :func:`~solver.io.write_mesh`, as ``morph`` does.

    Parameters
    ----------
    mesh : Mesh
        The mesh as read (a deck written in its own format keeps every byte
        but the node coordinates).
    pattern : str
        Output path; ``{i}`` becomes the plan row (from 1).
    file_format : str, optional
        meshio format name (default: the extension).
    nastran_large : bool
        Nastran decks: moved nodes that do not fit their 8-column fields as
        large-field ``GRID*`` cards (:func:`~solver.io.write_mesh`).
    flatten : bool
        Abaqus/CAE assembly decks: write each variant as one flat deck
        (:func:`~solver.io.write_mesh`'s ``flatten``).

    Returns
    -------
    callable
    """

    def write(row: int, res: DeformResult) -> str:
        path = pattern.replace("{i}", str(row))
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        write_mesh(mesh, res.V, path, file_format, nastran_large=nastran_large, flatten=flatten)
        return path

    return write


def summary_rows(result: DoeResult) -> list[dict[str, Any]]:
    """The summary table: one dict per variant (``row``, parameters, :data:`SUMMARY_FIELDS`)."""
    return [v.summary() for v in result.variants]


def write_summary(result: DoeResult, path: str | os.PathLike[str]) -> None:
    """Write the summary CSV: ``row``, one column per shape, then :data:`SUMMARY_FIELDS`.

    Numbers are written with 17 significant digits (they read back exactly);
    a missing value is an empty cell.
    """
    write_rows(path, ["row", *result.shapes, *SUMMARY_FIELDS], summary_rows(result))


def write_rows(path: str | os.PathLike[str], fields: list[str], rows: list[dict[str, Any]]) -> None:
    """A CSV of ``rows`` under the header ``fields``, to ``path`` or (``-``) to standard output.

    Floats are written to 17 significant digits, None as an empty cell.
    """

    def cell(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, (float, np.floating)):
            return format(float(v), ".17g")
        return str(v)

    def write(fh: IO[str]) -> None:
        w = csv.writer(fh)
        w.writerow(fields)
        for r in rows:
            w.writerow([cell(r.get(f)) for f in fields])

    if str(path) == "-":
        write(sys.stdout)
        sys.stdout.flush()
        return
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8", newline="") as fh:
        write(fh)

