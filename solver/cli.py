"""``tetmorph`` command line: inspect, tetrahedralize and morph FE meshes in pipelines.

Standard output carries only the JSON documents a command produces (``info``,
``features``, and ``--report -``); everything meant for people (what was
written, timings, progress of a set-up that takes longer than a second, what a
lossy write dropped) goes to standard error.

Exit codes:

* 0 -- success;
* 1 -- a typed tetmorph error: unreadable or invalid mesh, bad SPEC or MOVE, a
  write refused because the format would lose something (message on stderr;
  the error document in the REPORT when one was asked for);
* 2 -- usage: unknown command or option, missing argument (argparse);
* 3 -- ``morph``: at least one MOVE was rejected (inversion policy ``reject``);
  the others were written;
* 4 -- ``check``: some element fails a checked quality criterion (the table,
  the CSV and the element set are written all the same).

``check`` prints its table on standard output (it is what the command
produces); with ``--report -`` the JSON goes there instead and the table to
standard error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .documents import dump_json, load_json
from .errors import InversionError, SolverError
from .io import read_mesh, write_mesh
from .ops.unique import unique
from .options import add_solve_arguments, from_arguments

__all__ = ["main", "EXIT_OK", "EXIT_ERROR", "EXIT_USAGE", "EXIT_REJECTED", "EXIT_QUALITY"]

EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_REJECTED, EXIT_QUALITY = 0, 1, 2, 3, 4
#: Set-up progress is printed once it has lasted this long (seconds).
PROGRESS_AFTER = 1.0


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("tetmorph")
    except Exception:  # not installed: the package's own number
        from . import __version__

        return __version__


def _progress(after: float | None = None) -> Callable[[str, float], None]:
    """A ``progress(stage, fraction)`` callback that prints ``setup: stage fraction`` on stderr.

    Silent until set-up has lasted ``after`` seconds (:data:`PROGRESS_AFTER`).
    """
    t0 = time.monotonic()
    after = PROGRESS_AFTER if after is None else after

    def report(stage: str, fraction: float) -> None:
        elapsed = time.monotonic() - t0
        if elapsed >= after:
            _say(f"setup: {stage} {100 * fraction:.0f}% ({elapsed:.1f} s)")

    return report


def _dropped(w: Any, what: str) -> None:
    for d in w.dropped:
        _say(f"{what}: dropped {d['kind'].replace('_', ' ')} {d['name']!r} ({d['count']}): {d['reason']}")
    for old, new in w.renamed.items():
        _say(f"{what}: set {old!r} written as {new!r}")
    for s in w.skipped:
        _say(f"{what}: not written: {s}")


def cmd_info(args: argparse.Namespace) -> int:
    from .constraints.symmetry_candidates import abaqus_cyclic, resolve_cyclic, symmetry_candidates

    mesh = read_mesh(args.mesh, args.format)
    out = mesh.info()
    if not mesh.is_surface:  # ready-to-paste SPEC entries (SPEC.symmetry, SPEC.cyclic)
        out["symmetry"] = {"planes": symmetry_candidates(mesh),
                           "cyclic": [resolve_cyclic(mesh, e) for e in abaqus_cyclic(mesh.raw)]}
    dump_json(out, None)
    return EXIT_OK


def cmd_morph(args: argparse.Namespace) -> int:
    from .deform.deformer import Deformer

    if (args.move is None) == (args.moves is None):
        raise SolverError("give exactly one of --move MOVE.json or --moves MOVES.json", code="usage")
    mesh = read_mesh(args.mesh, args.format)
    spec = load_json(args.spec, "SPEC")
    if args.repair:
        if not isinstance(spec, dict):
            raise SolverError(f"{args.spec} must hold a JSON object (the SPEC)", code="invalid_json")
        spec = {**spec, "repair": True}
    if args.move is not None:
        moves = [load_json(args.move, "MOVE")]
    else:
        moves = load_json(args.moves, "MOVES")
        if not isinstance(moves, list) or not moves:
            raise SolverError(f"{args.moves} must hold a non-empty JSON list of MOVE documents",
                              code="invalid_json")
        if len(moves) > 1 and "{i}" not in args.output:
            raise SolverError("with several moves, --output needs '{i}' (e.g. out_{i}.vtu)",
                              code="usage")
    deformer = Deformer(mesh, spec, progress=_progress(), options=from_arguments(args))
    quality = "full" if args.quality else "basic"
    stacked: list[Any] | None = None
    if len(moves) > 1:  # one multi-column back-substitution for all of them
        try:
            stacked = deformer.solve_many(moves, args.inversion, quality)
        except InversionError:
            stacked = None  # some move is rejected: solve them one by one to report each
    reports = []
    for i, mv in enumerate(moves):
        out = args.output.replace("{i}", str(i))
        try:
            res = stacked[i] if stacked is not None else deformer.solve(mv, args.inversion, quality)
        except InversionError as e:
            reports.append({"move": i, "output": None, **e.report, "error": e.to_dict()})
            _say(f"move {i}: rejected, {e.message}")
            continue
        os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
        w = write_mesh(mesh, res.V, out, args.output_format, quality=args.quality, lossy=args.lossy,
                       nastran_large=args.nastran_large, flatten=args.flatten)
        _dropped(w, f"move {i}")
        rep = {"move": i, "output": out, **res.report, "written": w.to_dict()}
        reports.append(rep)
        t = rep["timings"]["update"]
        if rep.get("clamped"):
            _say(f"move {i}: clamped to {rep['applied_fraction']:.4f} of the move "
                 f"({rep['inverted_elements_unclamped']} elements inverted at full size)")
        _say(f"move {i}: wrote {out}  inverted={rep['inverted_elements']}  "
             f"min_sj={rep['min_scaled_jacobian']}  residual={rep['constraint_residual_max']:.3g}  "
             f"update={t['total_ms']:.1f} ms")
    _say(f"setup {deformer.setup_timings['total_ms']:.0f} ms ({deformer.solve_mode} solve, "
         f"{deformer.factorizations} factorizations for {len(moves)} moves)")
    if args.report:
        dump_json(reports[0] if args.move is not None else reports, args.report)
    rejected = sum(r["output"] is None for r in reports)
    return EXIT_REJECTED if rejected else EXIT_OK


def cmd_features(args: argparse.Namespace) -> int:
    from .constraints.features import feature_candidates, feature_region
    from .constraints.selection import select
    from .constraints.spec import parse_spec

    mesh = read_mesh(args.mesh, args.format)
    out: dict[str, Any] = {}
    if args.band:
        band = []
        for k, text in enumerate(args.band):
            try:
                band_sel = json.loads(text)
            except json.JSONDecodeError as e:
                raise SolverError(f"--band #{k + 1} is not valid JSON: {e}", code="invalid_json") from None
            parse_spec({"selections": {"band": band_sel}, "fixed": ["band"]})  # validates the selection
            band.append(select(mesh, band_sel, f"band {k + 1}"))
        region = feature_region(mesh, unique(np.concatenate(band)))
        out["region"] = {"vertices": int(region["ids"].size), "faces": int(region["faces"].size),
                         "area": region["area"], "cut_edges": int(region["cut_edges"].shape[0]),
                         "selection": {"ids": region["ids"].tolist()}}
        sets = {args.region_name: region["ids"]}
    else:
        cands = feature_candidates(mesh, args.angle, args.tol)
        out["candidates"] = [c.to_dict() for c in cands]
        sets = {c.name: c.ids for c in cands}
        for c in out["candidates"]:
            if not args.ids:
                c.pop("selection")
    if args.write:
        w = write_mesh(mesh, mesh.V, args.write, args.output_format, point_sets=sets, lossy=args.lossy)
        _dropped(w, args.write)
        out["written"] = {"path": args.write, "sets": sorted(sets), **w.to_dict()}
    dump_json(out, None)
    return EXIT_OK


def cmd_tetrahedralize(args: argparse.Namespace) -> int:
    from .io.read import read_surface
    from .io.tetrahedralize import tetrahedralize

    V, F = read_surface(args.surface, args.format)
    t0 = time.perf_counter()
    _say(f"tetrahedralizing {os.path.basename(args.surface)}: {len(V)} vertices, {len(F)} triangles (fTetWild)")
    mesh, info = tetrahedralize(V, F, edge_length=args.edge_length, edge_length_fac=args.edge_length_fac,
                                epsilon=args.epsilon, optimize=not args.no_optimize, allow_open=args.allow_open,
                                retry=not args.no_retry, log=_say, threads=args.threads)
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    w = write_mesh(mesh, mesh.V, args.output, args.output_format)
    used = info["used"]
    _say(f"wrote {args.output}: {mesh.n} vertices, {len(mesh.T)} tetrahedra in {time.perf_counter() - t0:.1f} s "
         f"(epsilon {used['epsilon']:g}, edge length "
         + (f"{used['edge_length']:g}" if used["edge_length"] else f"{used['edge_length_fac']:g} of the diagonal")
         + (", after a retry" if info["retried"] else "") + ")")
    if args.report:
        dump_json({"source": args.surface, "output": args.output, "vertices": mesh.n, "tetrahedra": int(len(mesh.T)),
               **info, "written": w.to_dict()}, args.report)
    return EXIT_OK


def _threshold(text: str) -> float | None:
    """A threshold argument: a number, or ``none`` (not checked)."""
    if text.strip().lower() == "none":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither a number nor 'none'") from None


def _cell(x: float | None) -> str:
    return "-" if x is None else f"{x:.6g}"


def quality_table(doc: dict[str, Any]) -> str:
    """The ``tetmorph check`` table of a :meth:`~solver.validity.criteria.QualityCheck.to_dict` document."""
    rows = [("criterion", "threshold", "failing", "worst", "element")]
    for r in doc["criteria"]:
        na = r["applicable"] == 0
        rows.append((r["name"], _cell(r["threshold"]), "n/a" if na else (str(r["failing"]) if r["checked"] else "-"),
                     "n/a" if na else _cell(r["worst"]), "" if r["worst_element"] is None else str(r["worst_element"])))
    widths = [max(len(row[k]) for row in rows) for k in range(5)]
    lines = ["  ".join(c.ljust(w) if k == 0 else c.rjust(w) for k, (c, w) in enumerate(zip(row, widths, strict=True)))
             for row in rows]
    verdict = "passed" if doc["passed"] else f"FAILED: {doc['failing_elements']} of {doc['elements']} elements"
    return "\n".join(lines) + f"\n{verdict}\n"


def cmd_check(args: argparse.Namespace) -> int:
    from .io.abaqus_deck import is_assembly
    from .io.element_sets import deck_element_ids, element_set
    from .validity.criteria import CRITERIA, preset, quality_check

    criteria = preset(args.preset)
    given = {k: getattr(args, k) for k in CRITERIA if getattr(args, k) is not _UNSET}
    criteria = criteria.replace(**given)
    mesh = read_mesh(args.mesh, args.format)
    if mesh.is_surface:
        raise SolverError(f"{args.mesh} is a triangle surface; 'check' measures volume elements",
                          code="not_a_volume_mesh")
    V, V0 = mesh.V, None
    if args.deformed:
        moved = read_mesh(args.deformed, args.deformed_format)
        if moved.V.shape != mesh.V.shape or moved.elements != mesh.elements:
            raise SolverError(f"{args.deformed} has {moved.n} nodes and {moved.elements} elements; {args.mesh} has "
                              f"{mesh.n} and {mesh.elements}: the deformed mesh must be the same mesh",
                              code="deformed_mismatch", nodes=[mesh.n, moved.n],
                              elements=[mesh.elements, moved.elements])
        V, V0 = moved.V, mesh.V
    ids = deck_element_ids(mesh)
    check = quality_check(V, mesh.T, criteria, cells=mesh.cells, T10=mesh.T10, V0=V0, ids=ids)
    doc = check.to_dict()
    if args.elset:  # refused before anything is written when the format has no element sets
        text = element_set(mesh.file_format, args.set_name, ids[check.failing], assembly=is_assembly(mesh))
        with open(args.elset, "w") as fh:
            fh.write(text)
        _say(f"wrote {args.elset}: {check.failing.size} elements in set {args.set_name}")
    if args.csv:
        with open(args.csv, "w") as fh:
            fh.write(check.csv())
        _say(f"wrote {args.csv}")
    table = quality_table(doc)
    if args.report == "-":
        print(table, file=sys.stderr, end="", flush=True)
    else:
        print(table, end="", flush=True)
    if args.report:
        dump_json({"mesh": args.mesh, "deformed": args.deformed, "preset": args.preset, **doc}, args.report)
    return EXIT_OK if check.passed else EXIT_QUALITY


#: Default of a threshold option not given (None means "not checked").
_UNSET: Any = object()


def _add_check(sub: Any) -> None:
    from .validity.criteria import CRITERIA, PRESETS

    pc = sub.add_parser("check", help="quality check against thresholds (a solver's preset, or your own): per "
                        f"criterion the failing count, worst value and element; exit {EXIT_QUALITY} when one fails")
    pc.add_argument("mesh")
    pc.add_argument("--preset", default="tetmorph", choices=sorted(PRESETS),
                    help="the thresholds to start from (docs/guide/validity.md gives their sources)")
    for name, (_, sense, what) in CRITERIA.items():
        pc.add_argument("--" + name.replace("_", "-"), dest=name, type=_threshold, default=_UNSET, metavar="X",
                        help=f"fail elements whose {what} is {'below' if sense == 'min' else 'above'} X; "
                        "'none': not checked")
    pc.add_argument("--deformed", help="the same mesh deformed (any format): checked there, volume change "
                    "against MESH")
    pc.add_argument("--csv", help="write the failing elements (deck id, criterion, value, threshold) as CSV")
    pc.add_argument("--elset", help="write the failing elements as an element set in the deck's syntax (Abaqus "
                    "*ELSET, Nastran SET1, Ansys CMBLOCK, LS-DYNA *SET_SOLID)")
    pc.add_argument("--set-name", default="FAILED_QUALITY", help="name of the --elset set")
    pc.add_argument("--report", help="write the result as JSON ('-': standard output)")
    pc.add_argument("--format", help="input meshio format name")
    pc.add_argument("--deformed-format", help="meshio format name of --deformed")
    pc.set_defaults(func=cmd_check)


def build_parser(extend: Callable[[Any], None] | None = None) -> argparse.ArgumentParser:
    """The ``tetmorph`` parser; ``extend(subparsers)`` may add commands (``serve``)."""
    p = argparse.ArgumentParser(
        prog="tetmorph", description="Deform tetrahedral FE meshes with exact hard constraints (mean "
        "curvature normals + mean value coordinates).", epilog="Exit codes: 0 success, 1 a typed error "
        "(message on stderr), 2 usage, 3 a MOVE rejected by the inversion policy, 4 a quality check failed. "
        "JSON (and the check's table) goes to stdout, messages and progress to stderr.")
    p.add_argument("--version", action="version", version=f"tetmorph {_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    pi = sub.add_parser("info", help="counts, element types, boundary/interior vertices, sets, quality, "
                        "flat elements at rest")
    pi.add_argument("mesh")
    pi.add_argument("--format", help="meshio format name when the extension does not tell")
    pi.set_defaults(func=cmd_info)
    pm = sub.add_parser("morph", help="deform a mesh for one MOVE or a list of MOVEs")
    pm.add_argument("mesh")
    pm.add_argument("--spec", required=True, help="SPEC.json: selections, fixed, handles, options")
    pm.add_argument("--move", help="MOVE.json: one handle update")
    pm.add_argument("--moves", help="MOVES.json: a list of MOVE documents (one factorization)")
    pm.add_argument("--output", required=True, help="output mesh; '{i}' is replaced by the move index")
    pm.add_argument("--report", help="write the REPORT (a list with --moves) as JSON; '-' for stdout")
    pm.add_argument("--format", help="input meshio format name")
    pm.add_argument("--output-format", help="output meshio format name")
    pm.add_argument("--quality", action="store_true", help="REPORT quality summaries before/after "
                    "and per-element metrics as cell data in the output (VTU, VTK, Gmsh)")
    pm.add_argument("--inversion", choices=["warn", "reject", "clamp"],
                    help="override the SPEC's inversion policy; 'clamp' writes the largest safe "
                    "fraction of an inverting MOVE")
    pm.add_argument("--repair", action="store_true", help="untangle inverted elements after each solve "
                    "(the SPEC's repair: true)")
    pm.add_argument("--lossy", action="store_true", help="write even when the output format cannot hold "
                    "everything the input carries (sets, element types, data); what is dropped is listed")
    pm.add_argument("--nastran-large", action="store_true", help="Nastran decks: write moved nodes whose "
                    "coordinates do not fit 8 columns exactly as large-field GRID* cards (16 columns)")
    pm.add_argument("--flatten", action="store_true", help="Abaqus/CAE assembly decks: write one flat deck (no "
                    "*Part/*Instance; every instance numbered apart), e.g. for CalculiX or instances morphed apart")
    add_solve_arguments(pm)
    pm.set_defaults(func=cmd_morph, kernels=True)
    pf = sub.add_parser("features", help="form-feature candidates (holes, bosses, planes) or the "
                        "min-cut feature region inside a band")
    pf.add_argument("mesh")
    pf.add_argument("--angle", type=float, default=30.0, help="sharp-edge dihedral angle, degrees")
    pf.add_argument("--tol", type=float, default=1e-3, help="fit tolerance relative to a patch's size")
    pf.add_argument("--band", action="append", help="a SELECTION (JSON) around a feature's border "
                    "(repeat for several border loops, e.g. both rims of a hole): print the region the "
                    "minimum cut separates instead of the candidates")
    pf.add_argument("--region-name", default="FEATURE", help="set name of the --band region")
    pf.add_argument("--ids", action="store_true", help="include each candidate's vertex ids")
    pf.add_argument("--write", help="write the mesh with the features as node sets")
    pf.add_argument("--format", help="input meshio format name")
    pf.add_argument("--output-format", help="output meshio format name")
    pf.add_argument("--lossy", action="store_true", help="write --write even when its format drops something")
    pf.set_defaults(func=cmd_features)
    pt = sub.add_parser("tetrahedralize", help="fill a closed surface (STL, OBJ, OFF, PLY) with tetrahedra "
                        "(fTetWild), retrying once with a tighter envelope when the result is not a valid "
                        "manifold mesh")
    pt.add_argument("surface")
    pt.add_argument("--output", required=True, help="the tet mesh to write (.vtu, .msh, .inp, ...)")
    pt.add_argument("--edge-length", type=float, help="absolute target edge length")
    pt.add_argument("--edge-length-fac", type=float, default=0.05,
                    help="target edge length / bounding-box diagonal (default 0.05)")
    pt.add_argument("--epsilon", type=float, default=1e-3, help="envelope / bounding-box diagonal (default 1e-3)")
    pt.add_argument("--no-optimize", action="store_true", help="skip fTetWild's quality optimisation (faster)")
    pt.add_argument("--allow-open", action="store_true", help="accept a surface with border edges")
    pt.add_argument("--no-retry", action="store_true", help="do not retry with epsilon / 2")
    pt.add_argument("--threads", type=int, default=0, help="fTetWild's threads (default 0: every core)")
    pt.add_argument("--report", help="write what was done (settings used, attempts) as JSON; '-' for stdout")
    pt.add_argument("--format", help="surface meshio format name")
    pt.add_argument("--output-format", help="output meshio format name")
    pt.set_defaults(func=cmd_tetrahedralize)
    _add_check(sub)
    from .workflows.commands import add_commands

    add_commands(sub)  # doe, bounds, sensitivities
    if extend is not None:
        extend(sub)
    return p


def main(argv: list[str] | None = None, extend: Callable[[Any], None] | None = None) -> int:
    """Run the ``tetmorph`` command line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; defaults to ``sys.argv[1:]``.
    extend : callable, optional
        Adds subcommands to the parser's subparsers (the service's ``serve``).

    Returns
    -------
    int
        The exit code (module docstring).
    """
    args = build_parser(extend).parse_args(argv)
    try:
        if getattr(args, "kernels", False):  # commands that factor: never a silent minute on a cold install
            from .kernels import announced, load_kernels

            with announced("loading the solver's compiled kernels"):
                load_kernels()
        return int(args.func(args))
    except SolverError as e:
        _say(f"tetmorph: error [{e.code}]: {e.message}")
        if getattr(args, "report", None):
            dump_json({"error": e.to_dict()}, args.report)
        return EXIT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
