"""Every subcommand writes data alone on stdout (JSON or CSV, as documented) and its messages on stderr."""

from __future__ import annotations

import csv
import io
import json

import meshio

from solver.cli import build_parser, main
from tests.conftest import DATA
from tests.solver.workflows.conftest import PLATE, SHAPES, SPEC

RESPONSE = "def response(deck):\n    return {'lines': float(len(deck.read_text().splitlines()))}\n"


def _json(text: str):
    return json.loads(text)


def _csv(text: str):
    rows = list(csv.DictReader(io.StringIO(text)))
    assert rows, "no CSV rows on stdout"
    return rows


def _table(text: str):
    """``tetmorph check``'s table: a header, one row per criterion, the verdict."""
    lines = text.splitlines()
    assert lines[0].split() == ["criterion", "threshold", "failing", "worst", "element"], lines[:1]
    assert len(lines) == 9 and (lines[-1] == "passed" or lines[-1].startswith("FAILED")), lines
    return lines


def _commands(tmp):
    from solver.testing import sphere_surface

    plan = tmp / "plan.csv"
    plan.write_text("bend,hole1_x\n0,0\n0.5,1\n")
    move = tmp / "move.json"
    move.write_text(json.dumps({"handles": {"end": {"translation": [0, 0, 1]}}}))
    surf = tmp / "ball.stl"
    meshio.write(surf, meshio.Mesh(*(lambda V, F: (V, [("triangle", F)]))(*sphere_surface(2))))
    resp = tmp / "resp.py"
    resp.write_text(RESPONSE)
    common = ["--spec", str(SPEC), "--shapes", str(SHAPES)]
    return {
        "info": ([str(DATA / "beam.node")], _json),
        "morph": ([str(PLATE), "--spec", str(SPEC), "--move", str(move), "--output", str(tmp / "m.inp"),
                   "--report", "-"], _json),
        "features": ([str(PLATE)], _json),
        "check": ([str(PLATE), "--preset", "calculix", "--csv", str(tmp / "bad.csv")], _table),
        "tetrahedralize": ([str(surf), "--output", str(tmp / "ball.vtu"), "--edge-length-fac", "0.3",
                            "--report", "-"], _json),
        "doe": ([str(PLATE), *common, "--plan", str(plan), "--output", str(tmp / "doe" / "{i}.inp"),
                 "--summary", "-"], _csv),
        "bounds": ([str(PLATE), *common, "--range", "-1", "1", "--tol", "0.25"], _json),
        "sensitivities": ([str(PLATE), *common, "--output", str(tmp / "sens.vtu")], None),
        "study": ([str(PLATE), *common, "--plan", str(plan), "--output", str(tmp / "st" / "{i}" / "deck.inp"),
                   "--solver", "true", "--response", str(resp), "--table", "-"], _csv),
        "optimize": ([str(PLATE), *common, "--output", str(tmp / "opt" / "{i}" / "deck.inp"), "--solver", "true",
                      "--response", str(resp), "--objective", "lines", "--bounds", "bend=-0.5:0.5",
                      "--bounds", "hole1_x=-1:1", "--bounds", "hole2_y=-1:1", "--bounds", "upper_x=-1:1",
                      "--max-evaluations", "3", "--history", "-"], _csv),
    }


def test_every_subcommand_keeps_stdout_for_data(tmp_path, capsys):
    cmds = _commands(tmp_path)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert set(sub.choices) == set(cmds), "a subcommand without a stdout check"
    for name, (args, parse) in cmds.items():
        assert main([name, *args]) == 0, name
        out, err = capsys.readouterr()
        if parse is None:  # writes files only: nothing on stdout
            assert out == "", f"{name} printed on stdout: {out[:200]!r}"
            assert err.strip(), f"{name} said nothing on stderr"
        else:
            parse(out)
    # the DOE's messages went to stderr, its table to stdout, one line per plan row
    main(["doe", *cmds["doe"][0]])
    out, err = capsys.readouterr()
    assert [r["row"] for r in _csv(out)] == ["1", "2"] and "row 1: wrote" in err


def test_two_outputs_on_stdout_are_refused(tmp_path, capsys):
    args, _ = _commands(tmp_path)["doe"]
    assert main(["doe", *args, "--report", "-"]) == 1  # a typed usage error, before any set-up
    assert "standard output" in capsys.readouterr().err


def test_doe_with_its_tables_in_files_prints_nothing_on_stdout(tmp_path, capsys):
    args, _ = _commands(tmp_path)["doe"]
    args = [a if a != "-" else str(tmp_path / "summary.csv") for a in args]
    assert main(["doe", *args, "--report", str(tmp_path / "r.json")]) == 0
    assert capsys.readouterr().out == ""
    assert len(_csv((tmp_path / "summary.csv").read_text())) == 2
