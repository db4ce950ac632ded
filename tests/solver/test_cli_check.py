"""``tetmorph check``: the table, the exit codes, and the CSV, element set and JSON it writes, read back here."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from solver.cli import EXIT_ERROR, EXIT_OK, EXIT_QUALITY, main
from solver.io import read_mesh, write_mesh
from solver.io.element_sets import deck_element_ids
from solver.validity.criteria import PRESETS, quality_check
from tests.conftest import DATA

BRACKET = str(DATA / "bracket.inp")


def elset_ids(text: str) -> list[int]:
    body = text.split("\n", 1)[1]
    assert text.startswith("*ELSET, ELSET=")
    return [int(f) for f in body.replace("\n", ",").split(",") if f.strip()]


def test_a_failing_check_writes_the_table_csv_elset_and_report(tmp_path, capsys):
    out_csv, out_set, report = tmp_path / "bad.csv", tmp_path / "bad.inp", tmp_path / "check.json"
    rc = main(["check", BRACKET, "--preset", "abaqus", "--max-aspect-ratio", "3", "--min-dihedral", "none",
               "--csv", str(out_csv), "--elset", str(out_set), "--set-name", "BAD", "--report", str(report)])
    assert rc == EXIT_QUALITY
    mesh = read_mesh(BRACKET)
    ids = deck_element_ids(mesh)
    lib = quality_check(mesh.V, mesh.T, PRESETS["abaqus"].replace(max_aspect_ratio=3.0, min_dihedral=None),
                        ids=ids)
    aspect = next(r for r in lib.results if r.name == "max_aspect_ratio")
    assert aspect.failing.size > 0
    table = capsys.readouterr().out
    row = next(ln.split() for ln in table.splitlines() if ln.startswith("max_aspect_ratio"))
    assert row == ["max_aspect_ratio", "3", str(aspect.failing.size), f"{aspect.worst:.6g}",
                   str(ids[aspect.worst_element])]
    assert next(ln.split() for ln in table.splitlines() if ln.startswith("min_dihedral"))[1:3] == ["-", "-"]
    assert f"FAILED: {lib.failing.size} of {len(mesh.T)} elements" in table
    with open(out_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {(int(r["element"]), r["criterion"]) for r in rows} == \
        {(int(i), "max_aspect_ratio") for i in ids[aspect.failing]}
    values = {int(r["element"]): float(r["value"]) for r in rows}
    np.testing.assert_allclose([values[int(i)] for i in ids[aspect.failing]], aspect.values, rtol=1e-15)
    assert elset_ids(out_set.read_text()) == sorted(ids[lib.failing].tolist())
    doc = json.loads(report.read_text())
    assert doc["preset"] == "abaqus" and doc["criteria"] == lib.to_dict()["criteria"]


def test_a_passing_check_exits_zero(capsys):
    assert main(["check", BRACKET, "--preset", "calculix"]) == EXIT_OK
    assert capsys.readouterr().out.rstrip().endswith("passed")


def test_report_dash_puts_json_alone_on_stdout(capsys):
    assert main(["check", BRACKET, "--preset", "calculix", "--report", "-"]) == EXIT_OK
    out, err = capsys.readouterr()
    assert json.loads(out)["passed"] is True and "criterion" in err


def test_deformed_checks_the_volume_change_against_rest(tmp_path, capsys):
    mesh = read_mesh(BRACKET)
    moved = tmp_path / "moved.inp"
    write_mesh(mesh, mesh.V * np.array([2.0, 1.0, 1.0]), str(moved))
    rc = main(["check", BRACKET, "--deformed", str(moved), "--preset", "calculix", "--max-volume-ratio", "1.5",
               "--report", str(tmp_path / "r.json")])
    assert rc == EXIT_QUALITY
    row = json.loads((tmp_path / "r.json").read_text())["criteria"][-1]
    assert row["name"] == "max_volume_ratio" and row["failing"] == len(mesh.T)
    assert abs(row["worst"] - 2.0) < 1e-9


def test_refusals(tmp_path, capsys):
    assert main(["check", BRACKET, "--deformed", str(DATA / "plate.inp")]) == EXIT_ERROR
    assert "[deformed_mismatch]" in capsys.readouterr().err
    target = tmp_path / "never.inp"
    assert main(["check", str(DATA / "screw.msh"), "--elset", str(target)]) == EXIT_ERROR
    assert "[element_sets_unsupported]" in capsys.readouterr().err and not target.exists()
    assert main(["check", str(DATA / "42400-IDGH.stl")]) == EXIT_ERROR
    assert "[not_a_volume_mesh]" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["check", BRACKET, "--max-aspect-ratio", "ten"])
    assert e.value.code == 2 and "--max-aspect-ratio" in capsys.readouterr().err
