"""SPEC/MOVE errors, the CLI, and the solver's independence from web code."""

from __future__ import annotations

import json
import subprocess
import sys

import meshio
import numpy as np
import pytest

from solver import SpecError, mesh_from_arrays, parse_move, parse_spec, precompute
from solver.cli import main
from solver.testing import cube_mesh

from .conftest import DATA

GOOD = {"selections": {"a": {"ids": [0]}, "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
        "fixed": ["a"], "handles": {"h": "b"}}


@pytest.mark.parametrize("patch,words", [
    ({"bogus": 1}, "unknown field"),
    ({"fixed": ["nope"]}, "unknown selection 'nope'"),
    ({"handles": {"h": "a"}}, "both fixed and a handle"),
    ({"handles": {"h": "b", "g": "b"}}, "more than one handle"),
    ({"laplacian": "fancy"}, "SPEC.laplacian: Input should be 'cotangent' or 'uniform'"),
    ({"constraints": {"method": "magic"}}, "SPEC.constraints.method: Input should be 'null_space', 'kkt'"),
    ({"constraints": {"method": "penalty", "penalty_weight": -1}},
     "SPEC.constraints.penalty_weight: Input should be greater than 0"),
    ({"inversion": "ignore"}, "SPEC.inversion: Input should be 'warn', 'reject' or 'clamp'"),
    ({"selections": {"a": {"ids": [0], "set": "A"}}, "fixed": ["a"], "handles": {}},
     r"SPEC.selections.a: .*exactly one of ids, set, box, sphere, plane; got ids and set"),
    ({"selections": {"a": {"box": {"min": [1, 1, 1], "max": [0, 0, 0]}}}, "fixed": ["a"], "handles": {}},
     "exceeds max"),
    ({"selections": {"a": {"sphere": {"center": [0, 0], "radius": 1}}}, "fixed": ["a"], "handles": {}},
     r"SPEC.selections.a.sphere.center: List should have at least 3 items"),
])
def test_spec_errors(patch, words):
    with pytest.raises(SpecError, match=words.replace("(", r"\(")):
        parse_spec({**GOOD, **patch})


def test_selection_errors_against_mesh():
    m = mesh_from_arrays(*cube_mesh(2))
    for sel, code in [({"ids": [999]}, "bad_selection"), ({"set": "missing"}, "unknown_set"),
                      ({"box": {"min": [5, 5, 5], "max": [6, 6, 6]}}, "empty_selection"),
                      ({"ids": []}, "empty_selection")]:
        with pytest.raises(SpecError) as e:
            precompute(m, {"selections": {"a": sel}, "fixed": ["a"]})
        assert e.value.code == code


def test_overlapping_handles_and_fixed_are_refused():
    m = mesh_from_arrays(*cube_mesh(2))
    top = {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}
    half = {"box": {"min": [0, 0, 0.5], "max": [1, 1, 1]}}
    with pytest.raises(SpecError, match="overlap"):
        precompute(m, {"selections": {"a": top, "b": half}, "handles": {"a": "a", "b": "b"}})
    with pytest.raises(SpecError, match="shares vertices"):
        precompute(m, {"selections": {"a": top, "b": half}, "fixed": ["a"], "handles": {"b": "b"}})


@pytest.mark.parametrize("move,words", [
    ({"handles": {"x": {}}}, "unknown handle"),
    ({"handles": {"h": {"translation": [1, 2]}}}, r"translation: List should have at least 3 items"),
    ({"handles": {"h": {"scale": 0}}}, r"MOVE.handles.h.scale: Input should be greater than or equal to 0.001, got 0"),
    ({"handles": {"h": {"rotation": {"axis": [0, 0, 0], "angle_deg": 10}}}}, "non-zero"),
    ({"handles": {"h": {"rotation": {"quaternion": [0, 0, 0, 0]}}}}, "non-zero"),
    ({"handles": {"h": {"translation": [float("nan"), 0, 0]}}}, "finite"),
    ({"handles": {"h": {"spin": 1}}}, "unknown field"),
])
def test_move_errors(move, words):
    with pytest.raises(SpecError, match=words):
        parse_move(move, ["h"])


def test_quaternion_and_axis_angle_agree():
    a = parse_move({"handles": {"h": {"rotation": {"axis": [0, 0, 2], "angle_deg": 90}}}}, ["h"])
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    b = parse_move({"handles": {"h": {"rotation": {"quaternion": [c, 0, 0, s]}}}}, ["h"])
    np.testing.assert_allclose(a.handles["h"].matrix, b.handles["h"].matrix, atol=1e-15)


def test_cli_info_and_morph(tmp_path, capsys):
    assert main(["info", str(DATA / "cones_with_cavities.inp")]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["boundary_shells"] == 3 and info["tetrahedra"] == 4722
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"selections": {
        "root": {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0], "tolerance": 1e-9}},
        "tip": {"plane": {"point": [0, 1, 0], "normal": [0, 1, 0], "tolerance": 1e-9}}},
        "fixed": ["root"], "handles": {"tip": "tip"}}))
    moves = tmp_path / "moves.json"
    moves.write_text(json.dumps([{"handles": {"tip": {"translation": [0.1 * k, 0, 0]}}} for k in range(3)]))
    out = tmp_path / "o_{i}.vtu"
    rep = tmp_path / "rep.json"
    assert main(["morph", str(DATA / "beam.node"), "--spec", str(spec), "--moves", str(moves),
                 "--output", str(out), "--report", str(rep)]) == 0
    reports = json.loads(rep.read_text())
    assert len(reports) == 3 and all(r["inverted_elements"] == 0 for r in reports)
    assert reports[0]["refactorized"] is False
    for k in range(3):
        pts = meshio.read(tmp_path / f"o_{k}.vtu").points
        tip = np.abs(pts[:, 1] - 1) < 1e-9
        np.testing.assert_allclose(pts[tip, 0] - meshio.read(DATA / "beam.node").points[tip, 0], 0.1 * k,
                                   atol=1e-12)


def test_cli_errors_exit_1_with_typed_message(tmp_path, capsys):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"selections": {"a": {"set": "nope"}}, "fixed": ["a"]}))
    mv = tmp_path / "mv.json"
    mv.write_text("{}")
    rep = tmp_path / "r.json"
    code = main(["morph", str(DATA / "beam.node"), "--spec", str(spec), "--move", str(mv),
                 "--output", str(tmp_path / "o.vtu"), "--report", str(rep)])
    assert code == 1
    assert "[unknown_set]" in capsys.readouterr().err
    assert json.loads(rep.read_text())["error"]["code"] == "unknown_set"
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["morph", str(DATA / "beam.node"), "--spec", str(bad), "--move", str(mv),
                 "--output", str(tmp_path / "o.vtu")]) == 1


def test_solver_imports_no_web_code():
    code = ("import sys, solver, solver.cli; bad = [m for m in sys.modules if m.split('.')[0] in "
            "('fastapi', 'pydantic', 'starlette', 'uvicorn')]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_singular_system_raises_factorization_error():
    import scipy.sparse as sp

    from solver import FactorizationError
    from solver.linalg.factorization import cholesky, lu

    with pytest.raises(FactorizationError) as e:
        cholesky(sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 1.0]])), "test system")
    assert "test system" in e.value.message and e.value.code == "singular_system"
    with pytest.raises(FactorizationError):
        cholesky(sp.csr_matrix(np.array([[np.nan, 0.0], [0.0, 1.0]])))
    with pytest.raises(FactorizationError):
        lu(sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 4.0]])), "test lu").solve(np.ones(2))


@pytest.mark.parametrize("with_nulls, without", [
    ({"points": [{"name": "p", "vertices": [5], "edge": None, "t": None}]},
     {"points": [{"name": "p", "vertices": [5]}]}),
    ({"relative": [{"name": "r", "vertices": None, "points": [{"vertices": [5]}, {"edge": [6, 7], "t": 0.5}]}]},
     {"relative": [{"name": "r", "points": [{"vertices": [5]}, {"edge": [6, 7], "t": 0.5}]}]}),
    ({"motion": [{"name": "m", "vertices": [5], "plane": None, "line": {"direction": [1, 0, 0]}}]},
     {"motion": [{"name": "m", "vertices": [5], "line": {"direction": [1, 0, 0]}}]}),
    ({"selections": {**GOOD["selections"], "b": {"ids": None, "set": None,
                                                  "box": {"min": [0, 0, 1], "max": [1, 1, 1]}}}}, {}),
    ({"ties": {"tolerance": 1e-9, "surface": None, "surface_tolerance": None}}, {"ties": {"tolerance": 1e-9}}),
    ({"domain": None, "constraints": None, "solve_options": None}, {}),
])
def test_a_null_field_of_a_spec_is_an_absent_one(with_nulls, without):
    """JSON ``null`` for an optional field means it is not given: the SPEC solves as the one without it."""
    mesh = mesh_from_arrays(*cube_mesh(3))
    move = {"handles": {"h": {"translation": [0.05, 0, 0.02]}}}
    a = precompute(mesh, {**GOOD, **with_nulls}).solve(move).V
    b = precompute(mesh, {**GOOD, **without}).solve(move).V
    assert np.array_equal(a, b)
