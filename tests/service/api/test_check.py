"""``GET /v1/meshes/{id}/check`` and ``GET /v1/sessions/{id}/check``: the numbers of the library and of the CLI."""

from __future__ import annotations

import csv
import io
import json

import numpy as np

from solver.cli import main
from solver.io import read_mesh
from solver.io.element_sets import deck_element_ids
from solver.validity.criteria import PRESETS, quality_check
from tests.conftest import DATA

from ..conftest import BRACKET, BRACKET_SPEC, MOVES, err, upload_bracket

QUERY = {"preset": "abaqus", "max_aspect_ratio": 3.0, "off": ["min_dihedral"]}


def test_the_mesh_check_answers_the_numbers_of_the_library_and_the_cli(client, tc, tmp_path):
    mesh_id = upload_bracket(client)["id"]
    r = tc.get(f"/v1/meshes/{mesh_id}/check", params=QUERY)
    assert r.status_code == 200, r.text
    doc = r.json()
    mesh = read_mesh(BRACKET)
    lib = quality_check(mesh.V, mesh.T, PRESETS["abaqus"].replace(max_aspect_ratio=3.0, min_dihedral=None),
                        ids=deck_element_ids(mesh)).to_dict(max_ids=1000)
    assert doc["criteria"] == lib["criteria"] and doc["passed"] is False and doc["deformed"] is False
    assert doc["failing_elements"] == lib["failing_elements"] > 0
    report = tmp_path / "cli.json"
    main(["check", str(BRACKET), "--preset", "abaqus", "--max-aspect-ratio", "3", "--min-dihedral", "none",
          "--report", str(report)])
    cli = json.loads(report.read_text())
    assert cli["criteria"] == doc["criteria"]  # the three give the same numbers
    row = next(c for c in doc["criteria"] if c["name"] == "max_aspect_ratio")
    assert row["ids"][0] >= 137  # the deck's numbers: its 136 triangles come first
    few = tc.get(f"/v1/meshes/{mesh_id}/check", params={**QUERY, "ids": 2}).json()
    assert next(c for c in few["criteria"] if c["name"] == "max_aspect_ratio")["ids"] == row["ids"][:2]


def test_csv_and_elset_answers_read_back(client, tc):
    mesh_id = upload_bracket(client)["id"]
    doc = tc.get(f"/v1/meshes/{mesh_id}/check", params=QUERY).json()
    failing = {c["name"]: c["ids"] for c in doc["criteria"] if c["failing"]}
    r = tc.get(f"/v1/meshes/{mesh_id}/check", params={**QUERY, "result": "csv"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO(r.text)))
    assert {(r_["criterion"], int(r_["element"])) for r_ in rows} == \
        {(name, i) for name, ids in failing.items() for i in ids}
    r = tc.get(f"/v1/meshes/{mesh_id}/check", params={**QUERY, "result": "elset", "set_name": "BAD"})
    head, _, body = r.text.partition("\n")
    assert head == "*ELSET, ELSET=BAD" and "attachment" in r.headers["content-disposition"]
    assert [int(f) for f in body.replace("\n", ",").split(",") if f.strip()] == \
        sorted({i for ids in failing.values() for i in ids})


def test_the_session_check_is_at_the_current_positions_against_rest(client, tc):
    mesh_id = upload_bracket(client)["id"]
    s = client.create_session(mesh_id, BRACKET_SPEC)
    client.deform(s["id"], MOVES[1])
    r = tc.get(f"/v1/sessions/{s['id']}/check", params={"preset": "tetmorph", "max_volume_ratio": 1.001})
    assert r.status_code == 200, r.text
    doc = r.json()
    mesh = read_mesh(BRACKET)
    P = client.positions(s["id"])
    lib = quality_check(P, mesh.T, PRESETS["tetmorph"].replace(max_volume_ratio=1.001), V0=mesh.V,
                        ids=deck_element_ids(mesh)).to_dict(max_ids=1000)
    assert doc["deformed"] is True and doc["criteria"] == lib["criteria"]
    ratio = next(c for c in doc["criteria"] if c["name"] == "max_volume_ratio")
    assert ratio["applicable"] == len(mesh.T) and ratio["failing"] > 0 and ratio["worst"] > 1.001


def test_quadratic_tets_are_checked_at_their_integration_points(client, tc):
    mesh_id = client.upload_mesh(DATA / "ccx_bracket.inp")["id"]
    doc = tc.get(f"/v1/meshes/{mesh_id}/check", params={"min_scaled_jacobian_ip": 0.3}).json()
    row = next(c for c in doc["criteria"] if c["name"] == "min_scaled_jacobian_ip")
    mesh = read_mesh(DATA / "ccx_bracket.inp")
    lib = quality_check(mesh.V, mesh.T, PRESETS["tetmorph"].replace(min_scaled_jacobian_ip=0.3), T10=mesh.T10,
                        ids=deck_element_ids(mesh))
    expect = next(r for r in lib.results if r.name == "min_scaled_jacobian_ip")
    assert row["applicable"] == len(mesh.T10) and row["failing"] == expect.failing.size > 0
    assert np.isclose(row["worst"], expect.worst, rtol=0, atol=0)


def test_refusals(client, tc):
    gmsh_id = client.upload_mesh(DATA / "screw.msh")["id"]
    r = tc.get(f"/v1/meshes/{gmsh_id}/check", params={"result": "elset"})
    assert r.status_code == 422 and err(r)["code"] == "element_sets_unsupported"
    assert err(r)["details"]["format"] == "gmsh"
    r = tc.get(f"/v1/meshes/{gmsh_id}/check", params={"preset": "ansa"})
    assert r.status_code == 422 and err(r)["code"] == "invalid_request" and "preset" in err(r)["message"]
    r = tc.get(f"/v1/meshes/{gmsh_id}/check", params={"off": "max_warpage"})
    assert r.status_code == 422 and err(r)["code"] == "invalid_request"
    surface_id = client.upload_mesh(DATA / "42400-IDGH.stl")["id"]
    r = tc.get(f"/v1/meshes/{surface_id}/check")
    assert r.status_code == 422 and err(r)["code"] == "not_a_volume_mesh" and err(r)["details"]["field"] == "mesh"
    assert tc.get("/v1/meshes/m_nothing/check").status_code == 404


def test_the_schemas_names_are_the_librarys():
    from typing import get_args

    from service.models.check import CriterionName, PresetName
    from solver.validity.criteria import CRITERIA

    assert list(get_args(CriterionName)) == list(CRITERIA) and set(get_args(PresetName)) == set(PRESETS)
