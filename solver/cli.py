"""``tetmorph`` command line: inspect and morph FE meshes in pipelines.

Exit codes: 0 success, 1 a typed tetmorph error (message on stderr, and the
error document in the REPORT file when one was asked for), 2 usage errors.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from .deform.deformer import precompute
from .errors import InversionError, SolverError
from .io import read_mesh, write_mesh

__all__ = ["main"]


def _load_json(path: str, what: str) -> Any:
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise SolverError(f"{what} file not found: {path}", code="file_not_found") from None
    except json.JSONDecodeError as e:
        raise SolverError(f"{what} file {path} is not valid JSON: {e}", code="invalid_json") from None


def _dump(obj: Any, path: str | None) -> None:
    text = json.dumps(obj, indent=2, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o))
    if path is None or path == "-":
        print(text)
    else:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")


def cmd_info(args: argparse.Namespace) -> int:
    mesh = read_mesh(args.mesh, args.format)
    _dump(mesh.info(), None)
    return 0


def cmd_morph(args: argparse.Namespace) -> int:
    if (args.move is None) == (args.moves is None):
        raise SolverError("give exactly one of --move MOVE.json or --moves MOVES.json", code="usage")
    mesh = read_mesh(args.mesh, args.format)
    spec = _load_json(args.spec, "SPEC")
    if args.move is not None:
        moves = [_load_json(args.move, "MOVE")]
    else:
        moves = _load_json(args.moves, "MOVES")
        if not isinstance(moves, list) or not moves:
            raise SolverError(f"{args.moves} must hold a non-empty JSON list of MOVE documents",
                              code="invalid_json")
        if len(moves) > 1 and "{i}" not in args.output:
            raise SolverError("with several moves, --output needs '{i}' (e.g. out_{i}.vtu)",
                              code="usage")
    deformer = precompute(mesh, spec)
    reports = []
    for i, mv in enumerate(moves):
        out = args.output.replace("{i}", str(i))
        try:
            res = deformer.solve(mv, args.inversion, "full" if args.quality else "basic")
        except InversionError as e:
            reports.append({"move": i, "output": None, **e.report, "error": e.to_dict()})
            print(f"move {i}: rejected, {e.message}", file=sys.stderr)
            continue
        os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
        write_mesh(mesh, res.V, out, args.output_format, quality=args.quality)
        rep = {"move": i, "output": out, **res.report}
        reports.append(rep)
        t = rep["timings"]["update"]
        if rep.get("clamped"):
            print(f"move {i}: clamped to {rep['applied_fraction']:.4f} of the move "
                  f"({rep['inverted_elements_unclamped']} elements inverted at full size)", file=sys.stderr)
        print(f"move {i}: wrote {out}  inverted={rep['inverted_elements']}  "
              f"min_sj={rep['min_scaled_jacobian']}  residual={rep['constraint_residual_max']:.3g}  "
              f"update={t['total_ms']:.1f} ms")
    print(f"setup {deformer.setup_timings['total_ms']:.0f} ms ({deformer.solve_mode} solve, "
          f"{deformer.factorizations} factorizations for {len(moves)} moves)")
    if args.report:
        _dump(reports[0] if args.move is not None else reports, args.report)
    rejected = sum(r["output"] is None for r in reports)
    return 1 if rejected else 0


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
        region = feature_region(mesh, np.unique(np.concatenate(band)))
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
        write_mesh(mesh, mesh.V, args.write, args.output_format, point_sets=sets)
        out["written"] = {"path": args.write, "sets": sorted(sets)}
    _dump(out, None)
    return 0


def build_parser(extend: Callable[[Any], None] | None = None) -> argparse.ArgumentParser:
    """The ``tetmorph`` parser; ``extend(subparsers)`` may add commands (``serve``)."""
    p = argparse.ArgumentParser(prog="tetmorph", description="Deform tetrahedral FE meshes with exact "
                                "hard constraints (mean curvature normals + mean value coordinates).")
    sub = p.add_subparsers(dest="command", required=True)
    pi = sub.add_parser("info", help="counts, element types, boundary/interior vertices, sets, quality")
    pi.add_argument("mesh")
    pi.add_argument("--format", help="meshio format name when the extension does not tell")
    pi.set_defaults(func=cmd_info)
    pm = sub.add_parser("morph", help="deform a mesh for one MOVE or a list of MOVEs")
    pm.add_argument("mesh")
    pm.add_argument("--spec", required=True, help="SPEC.json: selections, fixed, handles, options")
    pm.add_argument("--move", help="MOVE.json: one handle update")
    pm.add_argument("--moves", help="MOVES.json: a list of MOVE documents (one factorization)")
    pm.add_argument("--output", required=True, help="output mesh; '{i}' is replaced by the move index")
    pm.add_argument("--report", help="write the REPORT (a list with --moves) as JSON")
    pm.add_argument("--format", help="input meshio format name")
    pm.add_argument("--output-format", help="output meshio format name")
    pm.add_argument("--quality", action="store_true", help="REPORT quality summaries before/after "
                    "and per-element metrics as cell data in the output (VTU, VTK, Gmsh)")
    pm.add_argument("--inversion", choices=["warn", "reject", "clamp"],
                    help="override the SPEC's inversion policy; 'clamp' writes the largest safe "
                    "fraction of an inverting MOVE")
    pm.set_defaults(func=cmd_morph)
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
    pf.set_defaults(func=cmd_features)
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
        The exit code.
    """
    args = build_parser(extend).parse_args(argv)
    try:
        return int(args.func(args))
    except SolverError as e:
        print(f"tetmorph: error [{e.code}]: {e.message}", file=sys.stderr)
        if getattr(args, "report", None):
            _dump({"error": e.to_dict()}, args.report)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
