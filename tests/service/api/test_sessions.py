"""Session routes: create, deform, policies, positions, reset, delete, quality."""

from __future__ import annotations

import json

import meshio
import numpy as np
import pytest

from service.binary import decode_frame
from service.client import TetmorphError
from solver import read_mesh
from solver.deform.deformer import precompute
from solver.testing import cube_mesh
from tests.conftest import DATA

from ..conftest import BRACKET, BRACKET_SPEC, MOVES, err, running, upload_bracket


def test_inp_deck_end_to_end_matches_library(client, tc, tmp_path, bracket_library):
    d, expected = bracket_library
    mesh = upload_bracket(client)
    info = mesh["info"]
    assert info["tetrahedra"] == 4228 and info["vertices"] == 1213
    assert info["cell_types"] == {"triangle": 136, "tetra": 4228}  # two CPS3 end faces of 68
    assert {"FIXED", "LOAD", "SOLID"} <= set(info["sets"])
    assert info["quality"]["min_volume"] > 0
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    assert s["status"] == "ready" and s["handles"] == ["tip"]
    for move, V in zip(MOVES, expected, strict=True):
        X, report = client.deform(s["id"], move)
        assert report["inverted_elements"] == 0
        assert report["constraint_residual_max"] <= 1e-12
        np.testing.assert_allclose(X, V, rtol=0, atol=1e-12)
    # the session keeps the last MOVE: .inp and .vtu downloads carry its coordinates
    for fmt in ("inp", "vtu"):
        path = tmp_path / f"out.{fmt}"
        client.download_result(s["id"], path)
        m = meshio.read(path)
        np.testing.assert_allclose(m.points, expected[-1], rtol=0, atol=1e-9 * 100)
        assert sum(len(c.data) for c in m.cells if c.type == "tetra") == 4228
    inp = meshio.read(tmp_path / "out.inp")
    assert set(inp.point_sets) >= {"FIXED", "LOAD", "SOLID"}  # node sets survive
    assert client.session(s["id"])["updates"] == 3
    # JSON and displacement variants of the same MOVE agree with the binary body
    r = tc.post(f"/v1/sessions/{s['id']}/deform", json=MOVES[0],
                params={"kind": "displacements"})
    assert r.status_code == 200
    np.testing.assert_allclose(np.array(r.json()["displacements"]), expected[0] - d.mesh.V,
                               atol=1e-12)
    r = tc.post(f"/v1/sessions/{s['id']}/deform", json=MOVES[1],
                params={"result": "binary", "dtype": "float32"})
    X, head = decode_frame(r.content)
    assert X.dtype == np.float32 and head["shape"] == [1213, 3]
    np.testing.assert_allclose(X, expected[1], atol=1e-4)
    r = tc.post(f"/v1/sessions/{s['id']}/deform", json=MOVES[2],
                headers={"accept": "application/octet-stream"})
    assert decode_frame(r.content)[0].dtype == np.float64


def test_reject_policy_answers_422_and_leaves_session_unchanged(client, tc):
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    X0, _ = client.deform(s["id"], MOVES[0])
    bad = {"handles": {"tip": {"rotation": {"axis": [0, 1, 0], "angle_deg": 170},
                               "translation": [-90, 0, 0]}}}
    with pytest.raises(TetmorphError) as e:
        client.deform(s["id"], bad, inversion="reject")
    assert e.value.status == 422 and e.value.code == "inverted_elements"
    assert e.value.details["report"]["inverted_elements"] > 0
    np.testing.assert_array_equal(client.positions(s["id"]), X0)
    doc = client.session(s["id"])
    assert doc["last_move"] == MOVES[0] and doc["updates"] == 1
    # the same move with 'warn' is answered, with the count in the REPORT
    _, report = client.deform(s["id"], bad)
    assert report["inverted_elements"] > 0


def test_spec_errors_come_back_at_create_time(client, tc):
    mesh = upload_bracket(client)
    cases = [
        ({**BRACKET_SPEC, "selections": {"root": {"set": "NOPE"}, "tip": {"set": "LOAD"}}},
         "FIXED"),  # unknown set: the message lists the sets the file has
        ({**BRACKET_SPEC, "selections": {"root": {"set": "FIXED"},
                                         "tip": {"box": {"min": [500, 0, 0], "max": [600, 1, 1]}}}},
         "no vertex"),
        ({**BRACKET_SPEC, "fixed": ["ghost"]}, "ghost"),
        ({**BRACKET_SPEC, "solve": "sideways"}, "sideways"),
    ]
    for spec, word in cases:
        r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"], "spec": spec})
        e = err(r)
        assert r.status_code == 422, e
        assert word in e["message"], e["message"]
    cones = client.upload_mesh(DATA / "cones_with_cavities.inp")
    from tests.conftest import bend_spec, load

    r = tc.post("/v1/sessions", json={"mesh_id": cones["id"],
                                      "spec": bend_spec(load("cones_with_cavities.inp"),
                                                        boundary_only=True, voids="refuse")})
    assert r.status_code == 422 and err(r)["code"] == "unconstrained_shell"
    assert tc.get("/v1/sessions").json() == []  # nothing was stored
    r = tc.post("/v1/sessions", json={"mesh_id": "m_0000", "spec": BRACKET_SPEC})
    assert r.status_code == 404 and err(r)["code"] == "mesh_not_found"


def test_a_session_refused_at_build_leaves_no_record_even_after_a_restart(tmp_path):
    from service.client import Client

    from ..conftest import running

    spec = {**BRACKET_SPEC, "selections": {"root": {"set": "FIXED"}, "tip": {"set": "FIXED"}}}
    with running(tmp_path / "data") as tc:
        mesh = upload_bracket(Client(http=tc))
        for _ in range(3):
            r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"], "spec": spec})
            assert r.status_code == 422 and err(r)["code"] == "overlapping_constraints", err(r)
        assert tc.get("/v1/sessions").json() == []
        folder = tc.app.state.registry.store.sessions_dir
    assert not list(folder.glob("*.json")), "a refused session was written"
    with running(tmp_path / "data") as tc:  # a restart lists nothing either
        assert tc.get("/v1/sessions").json() == []


def test_a_specs_solve_options_may_set_only_what_the_operator_allows(tmp_path):
    from service.client import Client

    with running(tmp_path / "data", load_kernels=False) as tc:
        mesh = upload_bracket(Client(http=tc))
        for field in ("backend", "sweeps", "basis"):
            value = "scipy" if field == "backend" else False
            r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"],
                                              "spec": {**BRACKET_SPEC, "solve_options": {field: value}}})
            assert r.status_code == 422, r.text
            assert err(r)["code"] == "solve_option_not_allowed"
            assert err(r)["details"]["field"] == f"SPEC.solve_options.{field}"
        assert tc.get("/v1/sessions").json() == []  # nothing stored
        ok = {**BRACKET_SPEC, "solve_options": {"precision": "exact", "threads": 1, "backend": None}}
        r = tc.post("/v1/sessions?wait=true", json={"mesh_id": mesh["id"], "spec": ok})
        assert r.status_code in (200, 201, 202), r.text
    with running(tmp_path / "data2", load_kernels=False, spec_solve_options=["backend"]) as tc:
        mesh = upload_bracket(Client(http=tc))
        r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"],
                                          "spec": {**BRACKET_SPEC, "solve_options": {"backend": "scipy"}}})
        assert r.status_code in (200, 201, 202), r.text
        r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"],
                                          "spec": {**BRACKET_SPEC, "solve_options": {"threads": 1}}})
        assert r.status_code == 422 and err(r)["details"]["field"] == "SPEC.solve_options.threads"


def test_bad_move_is_422_and_keeps_state(client, tc):
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    client.deform(s["id"], MOVES[0])
    for move, word in (({"handles": {"nope": {}}}, "nope"),
                       ({"handles": {"tip": {"translation": [1, 2]}}}, "translation"),
                       ({"handles": {"tip": {"scale": -1}}}, "scale"),
                       ({"rotate": 1}, "rotate")):
        r = tc.post(f"/v1/sessions/{s['id']}/deform", json=move)
        assert r.status_code == 422 and word in err(r)["message"]
    assert client.session(s["id"])["last_move"] == MOVES[0]


def test_a_move_refused_for_its_query_is_not_committed(client, tc):
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    client.deform(s["id"], MOVES[0])
    before = client.session(s["id"])
    for fmt in ("zzz", "stl"):  # no such format; a surface format for a tet mesh
        r = tc.post(f"/v1/sessions/{s['id']}/deform", json=MOVES[1], params={"result": "mesh", "format": fmt})
        assert r.status_code == 422 and err(r)["code"] == "unknown_format"
    after = client.session(s["id"])
    assert after["last_move"] == MOVES[0] and after["updates"] == before["updates"]
    assert after["version"] == before["version"]


def test_a_move_whose_file_the_format_cannot_write_is_not_committed(client, tc, bracket_library):
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    client.deform(s["id"], MOVES[0])
    before = client.session(s["id"])
    assert before["version"] > 0
    for fmt in ("tetgen", "medit", "nastran"):  # offered formats that cannot hold the deck's sets
        r = tc.post(f"/v1/sessions/{s['id']}/deform", json=MOVES[1], params={"result": "mesh", "format": fmt})
        assert r.status_code == 422 and err(r)["code"] == "lossy_write", (fmt, r.text)
        after = client.session(s["id"])
        assert (after["version"], after["last_move"]) == (before["version"], MOVES[0]), fmt
    # the positions are still the library's for the last MOVE committed, not the refused one
    np.testing.assert_allclose(client.positions(s["id"]), bracket_library[1][0], rtol=0, atol=1e-9)


def test_a_mesh_with_nodes_at_plus_or_minus_1e308_is_refused_at_upload_and_no_session_is_made_on_it(tc, tmp_path):
    """Once stored at upload, such a mesh answered 500 at POST /v1/sessions (its tie search overflowed)."""
    from solver.limits import COORD_MAX

    from .test_meshes import TET, _inp_bytes

    huge = TET * np.array([1e308, -1e308, 1e308])  # finite, far beyond COORD_MAX
    src = tmp_path / "huge.vtu"
    meshio.write(src, meshio.Mesh(huge, [("tetra", np.array([[0, 1, 2, 3]]))]))
    for name, data in (("huge.inp", _inp_bytes(huge, [[0, 1, 2, 3]])), ("huge.vtu", src.read_bytes())):
        r = tc.post("/v1/meshes", files=[("file", (name, data))])
        e = err(r)
        assert r.status_code == 422 and e["code"] == "coordinates_out_of_range", (name, e)
        assert e["details"]["bound"] == COORD_MAX and e["details"]["vertices"] == [1, 2, 3], (name, e)
    r = tc.post("/v1/meshes/arrays", json={"vertices": huge.tolist(), "tetrahedra": [[0, 1, 2, 3]]})
    assert r.status_code == 422 and "vertices" in err(r)["message"]
    assert tc.get("/v1/meshes").json() == [] and tc.get("/v1/sessions").json() == []  # nothing stored
    # a node no element uses may lie anywhere: it is stored, and a session with ties is made on it
    extra = np.vstack([TET, [[1e308, -1e308, 1e308]]])
    mid = tc.post("/v1/meshes", files=[("file", ("extra.inp", _inp_bytes(extra, [[0, 1, 2, 3]])))]).json()["id"]
    spec = {"selections": {"a": {"ids": [0]}, "b": {"ids": [3]}}, "fixed": ["a"], "handles": {"h": "b"},
            "ties": "auto"}
    assert tc.post("/v1/sessions", json={"mesh_id": mid, "spec": spec}).status_code == 201


def test_arrays_upload_deform_reset_delete(client, tc):
    V, T = cube_mesh(4)
    top = np.flatnonzero(V[:, 2] == 1).tolist()
    bottom = np.flatnonzero(V[:, 2] == 0).tolist()
    mesh = client.upload_arrays(V, T, sets={"top": top, "bottom": bottom}, name="cube")
    assert mesh["info"]["tetrahedra"] == len(T) and mesh["info"]["sets"] == {"bottom": 25, "top": 25}
    spec = {"selections": {"b": {"set": "bottom"}, "t": {"set": "top"}},
            "fixed": ["b"], "handles": {"t": "t"}}
    s = client.create_session(mesh["id"], spec)
    X, rep = client.deform(s["id"], {"handles": {"t": {"translation": [0.2, 0, 0]}}})
    np.testing.assert_allclose(X[top, 0], V[top, 0] + 0.2, atol=1e-12)
    np.testing.assert_array_equal(X[bottom], V[bottom])
    client.reset(s["id"])
    np.testing.assert_array_equal(client.positions(s["id"]), V)
    r = tc.delete(f"/v1/meshes/{mesh['id']}")
    assert r.status_code == 409 and s["id"] in err(r)["message"]
    client.delete_session(s["id"])
    assert tc.get(f"/v1/sessions/{s['id']}").status_code == 404
    client.delete_mesh(mesh["id"])
    assert tc.get(f"/v1/meshes/{mesh['id']}").status_code == 404


def test_build_over_wait_answers_202_with_progress(tmp_path):
    with running(tmp_path, build_wait_s=0.0) as tc:
        mid = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))]).json()["id"]
        r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
        assert r.status_code == 202, r.json()
        assert r.headers["location"] == f"/v1/sessions/{r.json()['id']}"
        assert r.json()["status"] == "building" and 0 < r.json()["progress"] < 1
        from service.client import Client

        doc = Client(http=tc).create_session(mid, BRACKET_SPEC)  # polls until ready
        assert doc["status"] == "ready" and doc["progress"] == 1.0


def test_conflicting_constraints_are_reported_or_rejected(client, tc):
    """A point pulled away from a fixed vertex: reported in the REPORT, or refused with 'reject'."""
    mesh = upload_bracket(client)
    from solver import read_mesh

    V = read_mesh(BRACKET).V
    v = int(np.flatnonzero(np.abs(V[:, 0]) < 1e-9)[0])  # a node of the FIXED end
    spec = {**BRACKET_SPEC, "points": [{"name": "pull", "vertices": [v],
                                        "target": (V[v] + [0, 0, 1]).tolist()}]}
    s = client.create_session(mesh["id"], spec)
    rest = client.session(s["id"])["constraints_at_rest"]
    assert [c["name"] for c in rest["conflicting_constraints"]] == ["pull"]
    _, report = client.deform(s["id"], MOVES[0])
    (c,) = report["conflicting_constraints"]
    assert c["kind"] == "point" and c["vertices"] == [v] and abs(c["residual"] - 1) < 1e-9
    r = tc.post("/v1/sessions", json={"mesh_id": mesh["id"], "spec": {**spec, "conflicts": "reject"}})
    e = err(r)
    assert r.status_code == 422 and e["code"] == "conflicting_constraints"
    assert e["details"]["conflicting_constraints"][0]["name"] == "pull"
    # where: the node, the selections holding it (BRACKET_SPEC's "root", the FIXED set) and the
    # constraint on it, and by how much
    assert e["details"]["nodes"] == [v] and e["details"]["regions"] == [["root", "point pull"]]
    assert abs(e["details"]["residual"] - 1) < 1e-9
    # consistent at rest, conflicting after a MOVE: that MOVE is refused, the session keeps its state
    ok = {**BRACKET_SPEC, "points": [{"name": "p", "vertices": [v]}], "conflicts": "reject"}
    s2 = client.create_session(mesh["id"], ok)
    X0, rep0 = client.deform(s2["id"], MOVES[0])
    assert rep0["redundant_constraints"][0]["name"] == "p"
    with pytest.raises(TetmorphError) as ex:
        client.deform(s2["id"], {**MOVES[0], "points": {"p": [0, 0, 0]}})
    assert ex.value.status == 422 and ex.value.code == "conflicting_constraints"
    np.testing.assert_array_equal(client.positions(s2["id"]), X0)


def test_clamp_policy_over_http_and_websocket(client, tc, tmp_path):
    """An inverting MOVE with inversion=clamp: applied at its safe fraction, kept across a restart."""
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    bad = {"handles": {"tip": {"rotation": {"axis": [0, 1, 0], "angle_deg": 170},
                               "translation": [-90, 0, 0]}}}
    _, rep = client.deform(s["id"], bad)
    assert rep["inverted_elements"] > 0 and 0 < rep["safe_fraction"] < 1 and not rep["clamped"]
    X, rep2 = client.deform(s["id"], bad, inversion="clamp")
    assert rep2["clamped"] and rep2["inverted_elements"] == 0
    assert rep2["applied_fraction"] == rep["safe_fraction"]
    last = client.session(s["id"])["last_move"]
    assert last != bad  # the applied (scaled) MOVE is what the session keeps
    lib = precompute(read_mesh(BRACKET), BRACKET_SPEC).solve(last)
    np.testing.assert_allclose(X, lib.V, atol=1e-9)
    assert lib.report["inverted_elements"] == 0
    with tc.websocket_connect(f"/v1/sessions/{s['id']}/stream") as ws:
        ws.send_text(json.dumps({"seq": 1, "move": bad, "inversion": "clamp"}))
        _, head = decode_frame(ws.receive_bytes())
    assert head["report"]["clamped"] and head["report"]["inverted_elements"] == 0
    r = tc.post(f"/v1/sessions/{s['id']}/deform?inversion=sideways", json=bad)
    assert r.status_code == 422
    rep3 = tc.post(f"/v1/sessions/{s['id']}/deform?result=report&repair=true", json=bad).json()["report"]
    assert rep3["repair"]["attempted"] and rep3["repair"]["inverted_after"] <= rep["inverted_elements"]
    assert rep3["inverted_elements"] == rep3["repair"]["inverted_after"]


def test_quality_summaries_cell_data_and_per_element_arrays(client, tc, tmp_path):
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    r = tc.post(f"/v1/sessions/{s['id']}/deform?result=report&quality=full", json=MOVES[0])
    assert r.status_code == 200
    q = r.json()["report"]["quality"]
    assert q["before"]["aspect_ratio"]["min"] >= 1.0 - 1e-9
    assert sum(q["after"]["scaled_jacobian"]["histogram"]["counts"]) == 4228
    body = tc.get(f"/v1/sessions/{s['id']}/mesh?format=vtu&quality=true").content
    path = tmp_path / "q.vtu"
    path.write_bytes(body)
    back = meshio.read(path)
    assert "quality:min_dihedral_deg" in back.cell_data
    per = tc.get(f"/v1/sessions/{s['id']}/quality?metrics=scaled_jacobian,volume").json()
    assert per["elements"] == 4228 and set(per["per_element"]) == {"scaled_jacobian", "volume"}
    tets = np.concatenate([np.asarray(a) for a, c in zip(back.cell_data["quality:scaled_jacobian"],
                                                         back.cells, strict=True) if c.type == "tetra"])
    np.testing.assert_allclose(per["per_element"]["scaled_jacobian"], tets)
    r = tc.get(f"/v1/sessions/{s['id']}/quality?metrics=beauty")
    assert r.status_code == 422 and err(r)["code"] == "unknown_metric"


def test_moves_are_strict_and_bounded_and_a_failed_move_changes_nothing(client, tc):
    """Booleans and strings are not numbers; extreme values are refused naming the field; the session
    (GET /positions, bit for bit, and its record) is exactly as before every refused MOVE."""
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    client.deform(s["id"], MOVES[1])
    before = tc.get(f"/v1/sessions/{s['id']}/positions?result=binary").content
    doc0 = client.session(s["id"])
    bad = [
        ({"handles": {"tip": {"translation": [True, False, 0]}}}, "translation"),
        ({"handles": {"tip": {"translation": ["1", "0", "0"]}}}, "translation"),
        ({"handles": {"tip": {"scale": 1e300}}}, "scale"),
        ({"handles": {"tip": {"scale": 0.0}}}, "scale"),
        ({"handles": {"tip": {"translation": [1e300, 0, 0]}}}, "translation"),
        ({"handles": {"tip": {"pivot": [1e300, 0, 0]}}}, "pivot"),
        ({"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": float("1e400")}}}}, "angle_deg"),
        ({"handles": {"tip": {"translation": [0, 0, 1], "spin": 3}}}, "spin"),
        ({"handles": {"tip": {"rotation": {"quaternion": [1e300, 0, 0, 0]}}}}, "quaternion"),
        # beyond ten turns an angle holds no meaningful fraction of a turn: a mistake, refused
        ({"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": 1e300}}}}, "angle_deg"),
        ({"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": 1e6}}}}, "angle_deg"),
    ]
    for move, word in bad:
        r = tc.post(f"/v1/sessions/{s['id']}/deform", content=json.dumps(move).replace("Infinity", "1e400"),
                    headers={"content-type": "application/json"})
        e = err(r)
        assert r.status_code == 422, (move, e)
        assert word in e["message"], (word, e["message"])
    assert tc.get(f"/v1/sessions/{s['id']}/positions?result=binary").content == before
    doc = client.session(s["id"])
    assert doc["last_move"] == doc0["last_move"] == MOVES[1] and doc["updates"] == doc0["updates"]
    # an angle within the bound is a rotation like any other: reduced modulo 360, the same result as its remainder
    X1, rep = client.deform(s["id"], {"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": 3245.0}}}})
    X2, _ = client.deform(s["id"], {"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": 5.0}}}})
    np.testing.assert_array_equal(X1, X2)
    assert rep["finite"] is True and np.isfinite(X1).all()


def test_session_envelope_and_spec_are_strict(client, tc):
    mesh = upload_bracket(client)
    cases = [
        ({"mesh_id": mesh["id"], "spec": BRACKET_SPEC, "extra": 1}, "extra"),
        ({"mesh_id": mesh["id"], "spec": {**BRACKET_SPEC, "constraints": {"method": "penalty",
                                                                          "penalty_weight": 1e308}}},
         "penalty_weight"),
        ({"mesh_id": mesh["id"], "spec": {**BRACKET_SPEC, "repair": 1}}, "repair"),
        ({"mesh_id": mesh["id"], "spec": {**BRACKET_SPEC, "selections": {
            "root": {"box": {"min": [True, 0, 0], "max": [1, 1, 1]}}, "tip": {"set": "LOAD"}}}}, "min"),
    ]
    for body, word in cases:
        r = tc.post("/v1/sessions", json=body)
        e = err(r)
        assert r.status_code == 422 and word in e["message"], e
    assert tc.get("/v1/sessions").json() == []


def test_listings_are_paginated_and_filtered(client, tc):
    ids = [client.upload_arrays(*cube_mesh(1), name=f"cube{k}")["id"] for k in range(5)]
    r = tc.get("/v1/meshes?limit=2")
    assert [m["id"] for m in r.json()] == ids[:2] and "rel=\"next\"" in r.headers["link"]
    seen, cursor = [], None
    while True:
        r = tc.get("/v1/meshes", params={"limit": 2, **({"cursor": cursor} if cursor else {})})
        seen += [m["id"] for m in r.json()]
        cursor = r.headers.get("x-next-cursor")
        if cursor is None:
            break
    assert seen == ids
    assert [m["name"] for m in tc.get("/v1/meshes?name=cube3").json()] == ["cube3"]
    r = tc.get("/v1/meshes?cursor=bogus")
    assert r.status_code == 422 and err(r)["code"] == "invalid_request"


def test_sessions_are_listed_per_mesh(client, tc):
    a = client.upload_arrays(*cube_mesh(2), name="a")
    b = client.upload_arrays(*cube_mesh(2), name="b")
    spec = {"selections": {"lo": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                           "hi": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
            "fixed": ["lo"], "handles": {"h": "hi"}}
    sa = client.create_session(a["id"], spec)["id"]
    client.create_session(b["id"], spec)
    assert [s["id"] for s in tc.get("/v1/sessions", params={"mesh_id": a["id"]}).json()] == [sa]
    assert tc.get("/v1/sessions", params={"mesh_id": "m_none"}).json() == []


def test_a_morph_domain_holds_every_node_outside_it_through_the_service(client, tc):
    """SPEC.domain over REST: nodes outside the box stay at rest; a handle reaching outside is a 422."""
    mesh = read_mesh(BRACKET)  # 100 x 20 x 10 bar, FIXED at x = 0, LOAD at x = 100
    box = {"box": {"min": [70.0, -1.0, -1.0], "max": [101.0, 21.0, 11.0]}}
    spec = {**BRACKET_SPEC, "selections": {**BRACKET_SPEC["selections"], "near": box}, "domain": "near"}
    mid = upload_bracket(client)["id"]
    s = client.create_session(mid, spec)
    X, report = client.deform(s["id"], MOVES[0])
    outside = mesh.referenced & (mesh.V[:, 0] < 70.0)
    assert outside.sum() > 500
    assert np.array_equal(X[outside], mesh.V[outside])
    assert report["max_handle_displacement"] > 0 and "max_free_displacement" in report
    narrow = {**spec, "selections": {**spec["selections"], "near": {"box": {"min": [85.0, -1, -1],
                                                                             "max": [99.5, 21, 11]}}}}
    before = tc.get("/v1/sessions").json()
    r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": narrow})
    assert r.status_code == 422 and err(r)["code"] == "handle_outside_domain", err(r)
    assert tc.get("/v1/sessions").json() == before  # nothing stored
