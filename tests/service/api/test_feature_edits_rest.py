"""The fillet, distance and angle edits through REST and the CLI give the library's positions."""

from __future__ import annotations

import json

import meshio
import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.cli import main
from tests.gmsh_parts import filleted_bracket
from tests.service.conftest import err

SPEC = {"selections": {n.lower(): {"set": n} for n in ("FIXED", "FILLET", "INNER_H", "INNER_V", "BORE", "LOAD")},
        "fixed": ["fixed"],
        "fillet": [{"name": "corner", "selection": "fillet", "faces": ["inner_h", "inner_v"]}],
        "distance": [{"name": "pitch", "selection": "bore", "reference": "load"}]}
MOVE = {"fillet": {"corner": {"radius": 7.0}}, "distance": {"pitch": {"distance": 16.5}}}


@pytest.fixture(scope="module")
def part(tmp_path_factory):
    path = tmp_path_factory.mktemp("bracket") / "bracket.msh"
    filleted_bracket(path, size=3.0, order=1)
    return path


def test_a_fillet_and_a_distance_over_rest_and_the_cli_are_the_librarys(part, client, tc, tmp_path):
    mesh = read_mesh(part)
    want = precompute(mesh, SPEC).solve(MOVE)
    assert want.report["inverted_elements"] == 0
    sid = client.create_session(client.upload_mesh(part)["id"], SPEC)["id"]
    r = tc.post(f"/v1/sessions/{sid}/deform", json=MOVE)
    assert r.status_code == 200, r.text
    np.testing.assert_array_equal(np.asarray(r.json()["positions"]), want.V)
    spec, move = tmp_path / "spec.json", tmp_path / "move.json"
    spec.write_text(json.dumps(SPEC))
    move.write_text(json.dumps(MOVE))
    assert main(["morph", str(part), "--spec", str(spec), "--move", str(move), "--output",
                 str(tmp_path / "out.vtu")]) == 0
    np.testing.assert_array_equal(meshio.read(tmp_path / "out.vtu").points, want.V)
    bore, load = mesh.sets["BORE"], mesh.sets["LOAD"]  # the distance asked, measured on the written file
    got = meshio.read(tmp_path / "out.vtu").points
    assert np.linalg.norm(got[bore].mean(0) - got[load].mean(0)) == pytest.approx(16.5, rel=1e-12)


def test_a_bad_fillet_move_answers_the_librarys_code_over_rest(part, client, tc):
    sid = client.create_session(client.upload_mesh(part)["id"], SPEC)["id"]
    for move, field in (({"fillet": {"corner": {"radius": 7.0, "delta": 1.0}}}, "MOVE.fillet.corner"),
                        ({"fillet": {"nope": {"radius": 7.0}}}, "MOVE.fillet")):
        e = err(tc.post(f"/v1/sessions/{sid}/deform", json=move))
        assert e["code"] == "invalid_spec" and e["details"]["field"] == field, e
