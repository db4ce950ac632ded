"""PLAN files and rows: parsed values, and errors naming row, line and column."""

from __future__ import annotations

import numpy as np
import pytest

from solver import SolverError, SpecError
from solver.workflows.plan import parse_plan, plan_values, read_plan
from solver.workflows.shapes import parse_shapes
from tests.solver.workflows.conftest import PLAN, plate_shapes


def write(tmp_path, text, name="plan.csv", encoding="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding))
    return p


def test_readme_plan_reads_as_written():
    p = read_plan(PLAN)
    rows = [ln.split(",") for ln in PLAN.read_text().splitlines()]
    assert p.columns == tuple(rows[0])
    assert np.array_equal(p.values, np.array([[float(c) for c in r] for r in rows[1:]]))
    assert p.lines == tuple(range(2, len(rows) + 1))


def test_delimiters_bom_blank_lines_and_missing_columns(tmp_path, plate_deformer):
    shapes = parse_shapes(plate_shapes(), plate_deformer)
    p = read_plan(write(tmp_path, "\ufeffupper_x;bend\r\n1;2\r\n\r\n -0.5 ; 1e-3\r\n", encoding="utf-8"))
    assert p.columns == ("upper_x", "bend") and p.lines == (2, 4)
    theta = plan_values(p, shapes)  # shapes order: bend, hole1_x, hole2_y, upper_x; missing columns are 0
    assert theta.tolist() == [[2.0, 0.0, 0.0, 1.0], [1e-3, 0.0, 0.0, -0.5]]
    t = read_plan(write(tmp_path, "bend\thole1_x\n1\t2\n", "tab.csv"))
    assert t.values.tolist() == [[1.0, 2.0]]


@pytest.mark.parametrize("text, match, code", [
    ("bend,hole1_x\n1,2\n3,abc\n", r"plan row 2 \(line 3\), column 'hole1_x': 'abc' is not a number", "invalid_plan"),
    ("bend,hole1_x\n1,2\n\n3,\n", r"plan row 2 \(line 4\), column 'hole1_x': '' is not a number", "invalid_plan"),
    ("bend,hole1_x\n1,nan\n", r"plan row 1 \(line 2\), column 'hole1_x': 'nan' is not finite", "invalid_plan"),
    ("bend,hole1_x\n1,inf\n", "is not finite", "invalid_plan"),
    ("bend,hole1_x\n1,2,3\n", r"plan row 1 \(line 2\) has 3 cells, the header 2", "invalid_plan"),
    ("bend,bend\n1,2\n", r"plan columns \['bend'\] appear more than once", "invalid_plan"),
    ("bend,,x\n1,2,3\n", "plan column 2 has no name", "invalid_plan"),
    ("bend,hole1_x\n", "has a header but no rows", "empty_plan"),
    ("\n\n", "is empty", "empty_plan"),
])
def test_bad_plan_files(tmp_path, text, match, code):
    with pytest.raises(SpecError, match=match) as e:
        read_plan(write(tmp_path, text))
    assert e.value.code == code


def test_unknown_columns_name_them(plate_deformer):
    shapes = parse_shapes(plate_shapes(), plate_deformer)
    with pytest.raises(SpecError, match=r"plan column\(s\) \['hole9'\] name no shape") as e:
        plan_values(parse_plan([{"bend": 1, "hole9": 2}]), shapes)
    assert e.value.code == "unknown_shape" and e.value.details["columns"] == ["hole9"]


def test_missing_file_and_non_utf8(tmp_path):
    with pytest.raises(SolverError, match="PLAN file not found") as e:
        read_plan(tmp_path / "nope.csv")
    assert e.value.code == "file_not_found"
    with pytest.raises(SpecError, match="not UTF-8"):
        read_plan(write(tmp_path, "bend\n\xe9\n", encoding="latin-1"))


def test_rows_in_memory_are_json_numbers():
    p = parse_plan([{"a": 1, "b": 0.5}, {"b": -2}])
    assert p.columns == ("a", "b") and p.values.tolist() == [[1.0, 0.5], [0.0, -2.0]]
    assert parse_plan([[1, 2]], ["a", "b"]).values.tolist() == [[1.0, 2.0]]
    with pytest.raises(SpecError, match=r"plan row 2, column 'a': True is not a number"):
        parse_plan([{"a": 1}, {"a": True}])
    with pytest.raises(SpecError, match=r"plan row 1, column 'a': '1' is not a number"):
        parse_plan([{"a": "1"}])
    with pytest.raises(SpecError, match="no rows") as e:
        parse_plan([])
    assert e.value.code == "empty_plan"
    with pytest.raises(SpecError, match="must be an object"):
        parse_plan([[1, 2]])
    with pytest.raises(SpecError, match="a list of rows"):
        parse_plan("a,b\n1,2")  # type: ignore[arg-type]
