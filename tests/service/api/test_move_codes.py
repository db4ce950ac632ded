"""A bad MOVE or SPEC answers one error code and field, whichever layer finds it: library, CLI or REST.

The service validates request bodies before its routes run (FastAPI and the document models);
the library validates the same documents when it parses them. Both must say the same thing.
"""

from __future__ import annotations

import json

import pytest

from solver.cli import main
from solver.errors import SolverError
from tests.service.conftest import BRACKET, BRACKET_SPEC, err, upload_bracket

BAD_MOVES = {
    "unknown handle": {"handles": {"x": {"translation": [1, 0, 0]}}},
    "short translation": {"handles": {"tip": {"translation": [1, 2]}}},
    "zero scale": {"handles": {"tip": {"scale": 0}}},
    "zero axis": {"handles": {"tip": {"rotation": {"axis": [0, 0, 0], "angle_deg": 10}}}},
    "unknown member": {"handles": {"tip": {"spin": 1}}},
    "far translation": {"handles": {"tip": {"translation": [1e9, 0, 0]}}},
    "string number": {"handles": {"tip": {"translation": ["1", 0, 0]}}},
    "boolean number": {"handles": {"tip": {"translation": [True, 0, 0]}}},
    "unknown key": {"handlez": {}},
    "unknown edit": {"radius": {"bore": {"radius": 2}}},
    "not an object": [1, 2],
}


def _library(d, move) -> tuple[str, str | None]:
    with pytest.raises(SolverError) as e:
        d.solve(move)
    return e.value.code, e.value.details.get("field")


def _cli(tmp_path, move) -> tuple[str, str | None]:
    spec, mv, rep = tmp_path / "spec.json", tmp_path / "move.json", tmp_path / "report.json"
    spec.write_text(json.dumps(BRACKET_SPEC))
    mv.write_text(json.dumps(move))
    assert main(["morph", str(BRACKET), "--spec", str(spec), "--move", str(mv), "--output",
                 str(tmp_path / "out.inp"), "--report", str(rep)]) != 0
    e = json.loads(rep.read_text())["error"]
    return e["code"], e["details"].get("field")


def test_a_bad_move_answers_the_same_code_and_field_in_the_library_the_cli_and_rest(
        client, tc, bracket_library, tmp_path):
    d, _ = bracket_library
    sid = client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)["id"]
    seen = {}
    for name, move in BAD_MOVES.items():
        lib = _library(d, move)
        cli = _cli(tmp_path, move)
        r = tc.post(f"/v1/sessions/{sid}/deform", json=move)
        e = err(r)
        rest = (e["code"], e["details"].get("field"))
        assert r.status_code == 422, (name, e)
        assert lib == cli == rest, (name, lib, cli, rest)
        seen[name] = lib[0]
    assert set(seen.values()) == {"invalid_spec", "out_of_range"}  # the cases cover both codes
    assert tc.get(f"/v1/sessions/{sid}/history").json()["applied"] == []  # nothing stored from a refusal


def test_a_bad_spec_in_a_session_request_answers_the_librarys_code_and_field(client, tc):
    from solver import parse_spec

    mesh = upload_bracket(client)
    for spec in ({**BRACKET_SPEC, "fixed": "root"}, {**BRACKET_SPEC, "handles": {"tip": 3}},
                 {**BRACKET_SPEC, "extra": 1}):
        with pytest.raises(SolverError) as lib:
            parse_spec(spec)
        e = err(tc.post("/v1/sessions", json={"mesh_id": mesh["id"], "spec": spec}))
        assert (e["code"], e["details"].get("field")) == (lib.value.code, lib.value.details.get("field")), e
    assert tc.get("/v1/sessions").json() == []


def test_a_bad_request_that_is_no_document_keeps_its_code(client, tc):
    e = err(tc.post("/v1/sessions", json={"mesh_id": 3, "spec": BRACKET_SPEC}))
    assert e["code"] == "invalid_request"
