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


def test_the_session_names_each_edits_dimension_at_rest(part, client, tc):
    mesh = read_mesh(part)
    sid = client.create_session(client.upload_mesh(part)["id"], SPEC)["id"]
    doc = tc.get(f"/v1/sessions/{sid}").json()
    rest = {(d["kind"], d["name"]): d for d in doc["edits_at_rest"]}
    assert set(rest) == {("fillet", "corner"), ("distance", "pitch")}
    # the fillet was meshed on an arc of radius 5 (tests/gmsh_parts.py): its nodes lie on it
    assert rest["fillet", "corner"]["parameter"] == "radius"
    assert rest["fillet", "corner"]["rest"] == pytest.approx(5.0, rel=1e-9)
    # the distance between the centroids of the two sets, computed here from the mesh
    bore, load = mesh.V[mesh.sets["BORE"]].mean(0), mesh.V[mesh.sets["LOAD"]].mean(0)
    assert rest["distance", "pitch"]["parameter"] == "distance"
    assert rest["distance", "pitch"]["rest"] == pytest.approx(float(np.linalg.norm(bore - load)), rel=1e-12)
    # a change by delta lands at the stated rest value plus delta, measured on the positions answered
    r = tc.post(f"/v1/sessions/{sid}/deform", json={"distance": {"pitch": {"delta": 1.5}}})
    assert r.status_code == 200, r.text
    got = np.asarray(r.json()["positions"])
    measured = np.linalg.norm(got[mesh.sets["BORE"]].mean(0) - got[mesh.sets["LOAD"]].mean(0))
    assert measured == pytest.approx(rest["distance", "pitch"]["rest"] + 1.5, rel=1e-12)
