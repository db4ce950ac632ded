"""The doe, bounds and sensitivities commands end to end on the README example (tests/data/plate.inp)."""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys

import meshio
import numpy as np
import pytest

from solver import read_mesh
from solver.cli import main as tetmorph
from solver.deform.positions import MIXED_TOL
from solver.workflows.bounds import shape_bounds
from solver.workflows.commands import add_commands, main
from solver.workflows.plan import plan_values, read_plan
from solver.workflows.sensitivities import shape_sensitivities
from solver.workflows.shapes import parse_shapes
from tests.solver.workflows.conftest import PLAN, PLATE, SHAPES, SPEC, plate_shapes
from tests.solver.workflows.test_doe import hand_move, node_lines_differ_only_in_coordinates

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
COMMON = [str(PLATE), "--spec", str(SPEC), "--shapes", str(SHAPES)]


def test_doe_command_writes_decks_and_summary(tmp_path, capsys, plate_deformer):
    out = tmp_path / "decks" / "plate_{i}.inp"
    summary = tmp_path / "summary.csv"
    report = tmp_path / "report.json"
    rc = main(["doe", *COMMON, "--plan", str(PLAN), "--output", str(out), "--summary", str(summary),
               "--block", "3", "--report", str(report)])
    assert rc == 0
    stdout, text = capsys.readouterr()
    assert stdout == ""  # messages on stderr: stdout is for data
    assert "8 rows in 3 blocks of <= 3" in text and "row 8: wrote" in text
    with open(summary, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["file"] for r in rows] == [str(out).replace("{i}", str(i)) for i in range(1, 9)]
    assert json.loads(report.read_text())["reports"][5]["inverted_elements"] == 0
    # row 6 against tetmorph morph of the MOVE composed by hand (default SPEC: mixed precision)
    plan = read_plan(PLAN)
    mv = tmp_path / "move.json"
    mv.write_text(json.dumps(hand_move(*plan.values[5])))
    morph_out = tmp_path / "morph.inp"
    assert tetmorph(["morph", str(PLATE), "--spec", str(SPEC), "--move", str(mv), "--output", str(morph_out)]) == 0
    tol = 10 * MIXED_TOL * float(rows[5]["max_displacement"])  # the interior's stated accuracy
    node_lines_differ_only_in_coordinates(morph_out.read_bytes(), open(rows[5]["file"], "rb").read(), tol)
    assert np.abs(read_mesh(morph_out).V - read_mesh(rows[5]["file"]).V).max() <= tol


def test_doe_command_errors_name_the_cell(tmp_path, capsys):
    bad = tmp_path / "plan.csv"
    bad.write_text("bend,hole1_x\n1,0\n0,x1\n")
    rc = main(["doe", *COMMON, "--plan", str(bad), "--output", str(tmp_path / "o_{i}.inp"),
               "--summary", str(tmp_path / "s.csv")])
    err = capsys.readouterr().err
    assert rc == 1 and "tetmorph: error [invalid_plan]: plan row 2 (line 3), column 'hole1_x': 'x1'" in err
    assert "Traceback" not in err and not list(tmp_path.glob("o_*"))
    bad.write_text("bend,hole9\n1,0\n")
    assert main(["doe", *COMMON, "--plan", str(bad), "--output", str(tmp_path / "o_{i}.inp"),
                 "--summary", str(tmp_path / "s.csv")]) == 1
    assert "[unknown_shape]: plan column(s) ['hole9'] name no shape" in capsys.readouterr().err
    assert main(["doe", *COMMON, "--plan", str(PLAN), "--output", str(tmp_path / "o.inp"),
                 "--summary", str(tmp_path / "s.csv")]) == 1
    assert "--output needs '{i}'" in capsys.readouterr().err
    shapes = tmp_path / "shapes.json"
    shapes.write_text(json.dumps({"shapes": {"bend": {"handles": {"tip": {"translation": [1, 0, 0]}}}}}))
    assert main(["bounds", str(PLATE), "--spec", str(SPEC), "--shapes", str(shapes)]) == 1
    assert "[invalid_spec]: shape 'bend': MOVE names unknown handle(s) ['tip']" in capsys.readouterr().err


def test_rejected_rows_exit_1(tmp_path, capsys):
    plan = tmp_path / "plan.csv"
    plan.write_text("hole2_y\n0.5\n4\n")
    rc = main(["doe", *COMMON, "--plan", str(plan), "--output", str(tmp_path / "o_{i}.inp"),
               "--summary", str(tmp_path / "s.csv"), "--inversion", "reject"])
    assert rc == 1 and "row 2: rejected" in capsys.readouterr().err
    assert (tmp_path / "o_1.inp").exists() and not (tmp_path / "o_2.inp").exists()


def test_bounds_command_json(tmp_path, plate_deformer):
    out = tmp_path / "bounds.json"
    assert main(["bounds", *COMMON, "--range", "-3", "3", "--tol", "0.05", "--output", str(out)]) == 0
    doc = json.loads(out.read_text())
    ref = shape_bounds(plate_deformer, parse_shapes(plate_shapes(), plate_deformer), lo=-3, hi=3, tol=0.05)
    assert doc["bounds"] == {b.shape: b.to_dict() for b in ref.shapes}
    assert doc["bounds"]["hole2_y"]["positive"]["limit"] == "inversion"


def test_sensitivities_command_vtu(tmp_path, capsys, plate_deformer):
    out = tmp_path / "sens.vtu"
    assert main(["sensitivities", *COMMON, "--plan", str(PLAN), "--at", "6", "--output", str(out)]) == 0
    stdout, err = capsys.readouterr()
    assert stdout == "" and "at plan row 6 (line 7) (analytic)" in err
    m = meshio.read(out)
    shapes = parse_shapes(plate_shapes(), plate_deformer)
    ref = shape_sensitivities(plate_deformer, shapes, plan_values(read_plan(PLAN), shapes)[5])
    assert sorted(m.point_data) == sorted(["displacement", *(f"d_{n}" for n in shapes.names)])
    for k, n in enumerate(shapes.names):
        assert np.array_equal(m.point_data[f"d_{n}"], ref.derivatives[k])
    assert np.array_equal(m.points, ref.positions)
    assert main(["sensitivities", *COMMON, "--at", "2", "--output", str(out)]) == 1
    assert main(["sensitivities", *COMMON, "--plan", str(PLAN), "--at", "9", "--output", str(out)]) == 1
    assert "the plan has rows 1..8" in capsys.readouterr().err


def test_add_commands_registers_three_commands():
    p = argparse.ArgumentParser()
    add_commands(p.add_subparsers(dest="command", required=True))
    a = p.parse_args(["bounds", "m.inp", "--spec", "s", "--shapes", "h", "--range", "-1", "2"])
    assert a.command == "bounds" and a.range == [-1.0, 2.0] and callable(a.func)
    a = p.parse_args(["doe", "m.inp", "--spec", "s", "--shapes", "h", "--plan", "p", "--output", "o_{i}.inp",
                      "--summary", "s.csv"])
    assert a.block == 16 and a.inversion is None
    a = p.parse_args(["sensitivities", "m.inp", "--spec", "s", "--shapes", "h", "--output", "o.vtu"])
    assert a.at is None
    with pytest.raises(SystemExit):
        p.parse_args(["doe", "m.inp", "--spec", "s", "--shapes", "h"])  # --plan, --output, --summary required


def test_module_entry_point(tmp_path):
    env = {**os.environ, "PYTHONPATH": ROOT}
    r = subprocess.run([sys.executable, "-m", "solver.workflows", "bounds", *COMMON[:3], "--shapes",
                        str(tmp_path / "missing.json")], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 1 and "tetmorph: error [file_not_found]: SHAPES file not found" in r.stderr
