"""The ``doe``, ``bounds``, ``sensitivities``, ``study`` and ``optimize`` commands.

::

    tetmorph doe MESH --spec SPEC --shapes SHAPES --plan PLAN --output 'out_{i}.inp' --summary SUMMARY.csv
    tetmorph bounds MESH --spec SPEC --shapes SHAPES [--range LO HI]
    tetmorph sensitivities MESH --spec SPEC --shapes SHAPES [--plan PLAN --at ROW] --output SENS.vtu
    tetmorph study MESH --spec SPEC --shapes SHAPES --plan PLAN --solver 'ccx -i {stem}' --response ccx
      --output 'out/{i}/deck.inp' --table study.csv
    tetmorph optimize MESH --spec SPEC --shapes SHAPES --solver 'ccx -i {stem}' --response ccx
      --objective max_mises --constraint 'mass<=M' --output 'opt/{i}/deck.inp' --history history.csv

:func:`add_commands` registers them on an ``argparse`` subparsers object;
:func:`main` runs them alone (``python -m solver.workflows``). Exit codes as
``tetmorph``'s: 0 success, 1 a typed error (message on stderr) or a plan row
rejected, 2 usage errors.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from ..deform.deformer import Deformer, precompute
from ..documents import dump_json, load_json
from ..errors import SolverError
from ..io import read_mesh
from ..mesh import Mesh
from ..options import add_solve_arguments, from_arguments
from .batch_memory import keep_freed_memory
from .bounds import MAX_VALUE, TOL, shape_bounds
from .doe import BLOCK, deck_writer, run_doe, write_summary
from .optimize import (
    METHODS,
    STEP,
    Evaluation,
    default_bounds,
    parse_condition,
    run_optimize,
    write_history,
    write_plot,
)
from .plan import Plan, plan_values, read_plan
from .sensitivities import shape_sensitivities, write_sensitivities
from .shapes import Shapes, parse_shapes
from .study import DEFAULT_TIMEOUT_S, StudyRow, check_solver, load_reader, load_response, run_study, write_table

__all__ = ["add_commands", "build_parser", "main"]


def _setup(args: argparse.Namespace) -> tuple[Mesh, Deformer, Shapes]:
    """Read the mesh, factor the SPEC, parse the shapes (in that order of cost: documents first).

    The process runs one batch from here on, so it keeps freed memory for reuse
    (:func:`~solver.workflows.batch_memory.keep_freed_memory`).
    """
    keep_freed_memory()
    spec = load_json(args.spec, "SPEC")
    shapes_doc = load_json(args.shapes, "SHAPES")
    mesh = read_mesh(args.mesh, args.format)
    deformer = precompute(mesh, spec, options=from_arguments(args))
    return mesh, deformer, parse_shapes(shapes_doc, deformer)


def cmd_doe(args: argparse.Namespace) -> int:
    """``tetmorph doe``: one deck per plan row and a summary CSV."""
    plan = _plan_for(args, "out_{i}.inp")
    _one_stdout(summary=args.summary, report=args.report)
    mesh, deformer, shapes = _setup(args)
    writer = deck_writer(mesh, args.output, args.output_format, args.nastran_large, args.flatten)

    def output(row: int, res: Any) -> str | None:
        path = writer(row, res)
        r = res.report
        print(f"row {row}: wrote {path}  inverted={r['inverted_elements']}  min_sj={r['min_scaled_jacobian']}  "
              f"residual={r['constraint_residual_max']:.3g}", file=sys.stderr)
        return path

    result = run_doe(deformer, shapes, plan, block=args.block, output=output, inversion=args.inversion)
    for v in result.variants:
        if v.status != "ok":
            print(f"row {v.row}: {v.status}, inverted={v.inverted}; no deck written", file=sys.stderr)
    write_summary(result, args.summary)
    t = result.timings
    nb = -(-plan.rows // args.block)
    print(f"setup {deformer.setup_timings['total_ms']:.0f} ms ({deformer.solve_mode} solve, "
          f"{deformer.factorizations} factorizations); {plan.rows} rows in {nb} blocks of <= {args.block}: "
          f"solve {t['solve_ms']:.0f} ms ({t['per_variant_ms']:.1f} ms per variant), writing "
          f"{t['output_ms']:.0f} ms; summary {args.summary}", file=sys.stderr)
    if args.report:
        dump_json({**result.to_dict(), "reports": [v.report for v in result.variants]}, args.report)
    return 1 if any(v.status != "ok" for v in result.variants) else 0


def cmd_bounds(args: argparse.Namespace) -> int:
    """``tetmorph bounds``: per shape, the largest positive and negative value inverting nothing (JSON)."""
    lo, hi = (args.range if args.range is not None else (None, None))
    _, deformer, shapes = _setup(args)
    result = shape_bounds(deformer, shapes, lo=lo, hi=hi, tol=args.tol)
    dump_json(result.to_dict(), args.output)
    return 0


def cmd_sensitivities(args: argparse.Namespace) -> int:
    """``tetmorph sensitivities``: ``d_<shape>`` vectors per node at a plan row (default: rest)."""
    if (args.at is None) != (args.plan is None):
        raise SolverError("--at ROW and --plan PLAN go together (without them: the rest shape)", code="usage")
    plan = read_plan(args.plan) if args.plan is not None else None
    mesh, deformer, shapes = _setup(args)
    theta, where = np.zeros(shapes.count), "rest"
    if plan is not None:
        if not 1 <= args.at <= plan.rows:
            raise SolverError(f"--at {args.at}: the plan has rows 1..{plan.rows}", code="usage")
        theta, where = plan_values(plan, shapes)[args.at - 1], plan.where(args.at - 1)
    sens = shape_sensitivities(deformer, shapes, theta, where)
    write_sensitivities(mesh, sens, args.output, args.output_format)
    norms = {n: float(np.sqrt((sens.derivatives[k] ** 2).sum(axis=1)).max()) for k, n in enumerate(shapes.names)}
    print(f"wrote {args.output}: d_<shape> at {where} ({sens.method}); largest |dX/dtheta| per shape: "
          + ", ".join(f"{n} {v:.4g}" for n, v in norms.items()), file=sys.stderr)
    return 0


def cmd_study(args: argparse.Namespace) -> int:
    """``tetmorph study``: every plan row morphed, solved by the FE solver, its responses in one table."""
    plan = _plan_for(args, "out/{i}/deck.inp")
    if args.timeout <= 0:
        raise SolverError(f"--timeout must be > 0 seconds, got {args.timeout:g}", code="usage")
    check_solver(args.solver)  # before any cost: a missing program, a missing reader
    response = load_response(args.response)
    mesh, deformer, shapes = _setup(args)

    def progress(r: StudyRow) -> None:
        note = f"  ({r.message})" if r.message else ""
        print(f"row {r.row}: {r.status}" + (f" in {r.solver_s:.1f} s" if r.solver_s is not None else "") + note,
              file=sys.stderr)

    rows = run_study(mesh, deformer, shapes, plan, output=args.output, solver=args.solver, response=response,
                     timeout=args.timeout, block=args.block, inversion=args.inversion, progress=progress,
                     nastran_large=args.nastran_large)
    write_table(rows, shapes.names, args.table)
    ok = sum(r.status == "ok" for r in rows)
    print(f"{ok} of {len(rows)} rows solved; table {args.table}", file=sys.stderr)
    return 0 if ok == len(rows) else 1


def _plan_for(args: argparse.Namespace, example: str) -> Plan:
    """The ``--plan`` of a command that writes one deck per row; refused when ``--output`` cannot name the rows."""
    plan = read_plan(args.plan)
    if plan.rows > 1 and "{i}" not in args.output:
        raise SolverError("with several plan rows, --output needs '{i}' (the plan row, from 1), "
                          f"e.g. {example}", code="usage")
    return plan


def _plan_options(p: argparse.ArgumentParser, output_help: str) -> None:
    """``--plan``, ``--output`` and ``--block`` of the commands that solve a plan row by row (doe, study)."""
    p.add_argument("--plan", required=True, help="PLAN.csv: header of shape names, one variant per row")
    p.add_argument("--output", required=True, help=output_help)
    p.add_argument("--block", type=int, default=BLOCK, help=f"rows per stacked solve (default {BLOCK})")
    _nastran_option(p)


def _nastran_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--nastran-large", action="store_true", help="Nastran decks: write moved nodes whose "
                   "coordinates do not fit 8-column fields as large-field GRID* cards")
    p.add_argument("--flatten", action="store_true", help="Abaqus/CAE assembly decks: write one flat deck "
                   "(no *Part/*Instance; every instance numbered apart) instead of patching the parts")


def _one_stdout(**paths: str | None) -> None:
    """Refuse two outputs sent to standard output (``-``) at once: a pipeline could not tell them apart."""
    on = [f"--{k}" for k, v in paths.items() if v == "-"]
    if len(on) > 1:
        raise SolverError(f"{' and '.join(on)} both write to standard output ('-'); send one to a file",
                          code="usage")


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh")
    p.add_argument("--spec", required=True, help="SPEC.json: selections, fixed, handles, options")
    p.add_argument("--shapes", required=True, help="SHAPES.json: {\"shapes\": {NAME: MOVE, ...}}, each MOVE "
                   "at parameter value 1")
    p.add_argument("--format", help="input meshio format name when the extension does not tell")
    add_solve_arguments(p)


def _assignments(items: list[str] | None, what: str, pair: bool) -> dict[str, Any]:
    """``NAME=LO:HI`` (``pair``) or ``NAME=VALUE`` options as a dict."""
    out: dict[str, Any] = {}
    for text in items or []:
        name, eq, rest = text.partition("=")
        parts = rest.split(":") if pair else [rest]
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            vals = []
        if not eq or not name.strip() or len(vals) != (2 if pair else 1):
            form = "NAME=LO:HI" if pair else "NAME=VALUE"
            raise SolverError(f"--{what} {text!r}: expected {form}", code="usage")
        out[name.strip()] = tuple(vals) if pair else vals[0]
    return out


def cmd_optimize(args: argparse.Namespace) -> int:
    """``tetmorph optimize``: a response minimized over the shape parameters, the FE solver in the loop."""
    if "{i}" not in args.output:
        raise SolverError("--output needs '{i}' (the evaluation, from 1), e.g. opt/{i}/deck.inp", code="usage")
    if args.timeout <= 0:
        raise SolverError(f"--timeout must be > 0 seconds, got {args.timeout:g}", code="usage")
    _one_stdout(history=args.history, result=args.result)
    conditions = [parse_condition(c) for c in args.constraint or []]
    given = _assignments(args.bounds, "bounds", pair=True)
    starts = _assignments(args.start, "start", pair=False)
    check_solver(args.solver)
    response, gradient = load_reader(args.response)
    if args.no_gradient or args.method != "slsqp":
        gradient = None
    mesh, deformer, shapes = _setup(args)
    unknown = sorted(set(starts) - set(shapes.names))
    if unknown:
        raise SolverError(f"--start names {unknown}, not shapes of SHAPES (shapes: {list(shapes.names)})",
                          code="usage")
    bounds = default_bounds(deformer, shapes, given)
    print("bounds: " + ", ".join(f"{n} [{lo:.6g}, {hi:.6g}]" for n, (lo, hi) in zip(shapes.names, bounds,
                                                                                    strict=True)), file=sys.stderr)
    start = np.array([starts.get(n, 0.0) for n in shapes.names])

    def progress(e: Evaluation) -> None:
        got = f"{args.objective}={e.objective:.6g}" if e.objective is not None else e.study.status
        print(f"evaluation {e.index} (iteration {e.iteration}, {e.role}): {got}"
              + (f"  ({e.study.message})" if e.study.message else ""), file=sys.stderr)

    result = run_optimize(mesh, deformer, shapes, output=args.output, solver=args.solver, response=response,
                          objective=args.objective, constraints=conditions, maximize=args.maximize, bounds=bounds,
                          start=start, method=args.method, max_evaluations=args.max_evaluations, step=args.step,
                          timeout=args.timeout, gradient=gradient, progress=progress,
                          nastran_large=args.nastran_large)
    write_history(result, shapes.names, args.objective, args.history)
    if args.plot:
        write_plot(result, args.objective, args.plot)
    best = result.best
    summary = {"status": result.status, "message": result.message, "evaluations": len(result.history),
               "bounds": {n: list(b) for n, b in zip(shapes.names, result.bounds.tolist(), strict=True)},
               "start": _evaluation_doc(result.start, args.objective), "best": _evaluation_doc(best, args.objective)}
    if args.result:
        dump_json(summary, args.result)
    if best is None:
        print(f"{result.status}: no feasible evaluation ({result.message}); history {args.history}", file=sys.stderr)
        return 1
    print(f"{result.status} after {len(result.history)} evaluations ({result.message}): best {args.objective} "
          f"{best.objective:.6g} at evaluation {best.index} ({best.study.deck}); history {args.history}",
          file=sys.stderr)
    return 0


def _evaluation_doc(e: Evaluation | None, objective: str) -> dict[str, Any] | None:
    if e is None:
        return None
    return {"evaluation": e.index, "parameters": e.study.parameters, objective: e.objective,
            "feasible": e.feasible, "slacks": e.slacks, "responses": e.study.responses, "deck": e.study.deck}


def add_commands(subparsers: Any) -> None:
    """Register ``doe``, ``bounds`` and ``sensitivities`` on an ``argparse`` subparsers object.

    Each sets ``func`` (``func(args) -> exit code``, raising
    :class:`~solver.errors.SolverError` for typed errors).
    """
    pd = subparsers.add_parser("doe", help="morph every row of a PLAN (CSV, one column per shape): one deck "
                               "per row and a summary CSV, one factorization, rows stacked per back-substitution")
    _common(pd)
    _plan_options(pd, "output mesh per row; '{i}' is the plan row (from 1)")
    pd.add_argument("--summary", required=True, help="SUMMARY.csv ('-': standard output): row, parameters, "
                    "inverted, min_scaled_jacobian, max_displacement, constraint_residual_max, file, status")
    pd.add_argument("--inversion", choices=["warn", "reject", "clamp"], help="override the SPEC's inversion "
                    "policy; 'reject' writes no deck for an inverting row")
    pd.add_argument("--report", help="write every row's REPORT as JSON ('-': standard output)")
    pd.add_argument("--output-format", help="output meshio format name")
    pd.set_defaults(func=cmd_doe, kernels=True)
    pb = subparsers.add_parser("bounds", help="per shape, the largest positive and negative parameter with 0 "
                               "inverted elements (bisection on back-substitutions), as JSON")
    _common(pb)
    pb.add_argument("--range", nargs=2, type=float, metavar=("LO", "HI"), help="search LO <= value <= HI "
                    f"(LO <= 0 <= HI); default: 1, 2, 4, ... up to {MAX_VALUE:g} each way")
    pb.add_argument("--tol", type=float, default=TOL, help=f"final bracket width (default {TOL:g})")
    pb.add_argument("--output", help="write the JSON here (default: standard output)")
    pb.set_defaults(func=cmd_bounds, kernels=True)
    ps = subparsers.add_parser("sensitivities", help="dX/dtheta per node for every shape (analytic), as point "
                               "data d_<shape> of the variant's mesh")
    _common(ps)
    ps.add_argument("--plan", help="PLAN.csv with the row to differentiate at")
    ps.add_argument("--at", type=int, metavar="ROW", help="plan row (from 1); default: the rest shape")
    ps.add_argument("--output", required=True, help="output mesh with point data (VTU: .vtu)")
    ps.add_argument("--output-format", help="output meshio format name")
    ps.set_defaults(func=cmd_sensitivities, kernels=True)
    pt = subparsers.add_parser("study", help="every row of a PLAN morphed, written, run through an FE solver "
                               "command and its responses read into one table (CSV)")
    _common(pt)
    _plan_options(pt, "deck per row; '{i}' is the plan row (from 1)")
    _solver_options(pt)
    pt.add_argument("--table", required=True, help="STUDY.csv ('-': standard output): row, parameters, status, "
                    "mesh figures, solver time, responses, deck, message")
    pt.add_argument("--inversion", choices=["warn", "reject", "clamp"], default="reject",
                    help="the morph's inversion policy (default reject: an inverting row is recorded, not solved)")
    pt.set_defaults(func=cmd_study, kernels=True)
    po = subparsers.add_parser("optimize", help="minimize an FE response over the shape parameters (SLSQP or "
                               "COBYQA), every evaluation morphed, written and solved as a study row")
    _common(po)
    _solver_options(po)
    po.add_argument("--objective", required=True, help="the response to minimize, e.g. max_mises")
    po.add_argument("--maximize", action="store_true", help="maximize the objective instead")
    po.add_argument("--constraint", action="append", metavar="NAME<=VALUE",
                    help="a response constraint, NAME<=VALUE or NAME>=VALUE (repeatable)")
    po.add_argument("--bounds", action="append", metavar="NAME=LO:HI", help="a shape's search range "
                    "(repeatable); default: 0.8 x its safe range (tetmorph bounds)")
    po.add_argument("--start", action="append", metavar="NAME=VALUE", help="a shape's start value (default 0)")
    po.add_argument("--method", choices=METHODS, default="slsqp", help="slsqp (forward differences, default) "
                    "or cobyqa (derivative-free)")
    po.add_argument("--max-evaluations", type=int, default=40, help="solver runs at most (default 40)")
    po.add_argument("--no-gradient", action="store_true", help="difference the responses even when the "
                    "response file defines gradient(deck)")
    po.add_argument("--step", type=float, default=STEP, help=f"forward-difference step, as a fraction of each "
                    f"shape's range (default {STEP:g})")
    po.add_argument("--output", required=True, help="deck per evaluation; '{i}' is the evaluation (from 1)")
    _nastran_option(po)
    po.add_argument("--history", required=True, help="HISTORY.csv ('-': standard output): evaluation, "
                    "iteration, role, parameters, status, objective, feasible, slacks, responses, deck")
    po.add_argument("--plot", help="an SVG chart of the objective against the iterations")
    po.add_argument("--result", help="the start, the best evaluation and the status as JSON ('-': standard output)")
    po.set_defaults(func=cmd_optimize, kernels=True)


def _solver_options(p: argparse.ArgumentParser) -> None:
    """``--solver``, ``--response`` and ``--timeout`` of the commands that run an FE solver (study, optimize)."""
    p.add_argument("--solver", required=True, help="solver command run in the deck's folder; {stem}, {deck}, "
                   "{dir} and {i} are substituted (e.g. 'ccx -i {stem}')")
    p.add_argument("--response", default="ccx", help="'ccx' (CalculiX .dat: max_displacement, max_mises, "
                   "mass, freq_k) or a Python file defining response(deck) -> dict of floats")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S,
                   help=f"seconds per solver run (default {DEFAULT_TIMEOUT_S:g}); a run past it is recorded")


def build_parser() -> argparse.ArgumentParser:
    """A parser with the three commands alone (``python -m solver.workflows``)."""
    p = argparse.ArgumentParser(prog="python -m solver.workflows", description="Shape variables: DOE plans, "
                                "safe bounds and sensitivities of tetmorph morphs.")
    add_commands(p.add_subparsers(dest="command", required=True))
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one command; typed errors print ``tetmorph: error [code]: message`` and return 1."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except SolverError as e:
        print(f"tetmorph: error [{e.code}]: {e.message}", file=sys.stderr)
        return 1
