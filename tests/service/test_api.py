"""End-to-end tests of the REST service through FastAPI's TestClient."""

from __future__ import annotations

import json

import meshio
import numpy as np
import pytest

from service.binary import decode_bundle, decode_frame
from service.client import TetmorphError
from solver import read_mesh
from solver.deform.deformer import precompute
from solver.testing import cube_mesh, sphere_surface
from tests.conftest import DATA

from .conftest import BEAM_SPEC, BRACKET, BRACKET_SPEC, err, running, upload_bracket

MOVES = [
    {"handles": {"tip": {"translation": [0.0, 0.0, 4.0]}}},
    {"handles": {"tip": {"translation": [0.0, 2.0, -3.0],
                         "rotation": {"axis": [1, 0, 0], "angle_deg": 15}}}},
    {"handles": {"tip": {"translation": [5.0, 0.0, 0.0], "scale": 1.05}}},
]


@pytest.fixture(scope="module")
def bracket_library():
    """The library's result for each MOVE, to compare the service against."""
    d = precompute(read_mesh(BRACKET), BRACKET_SPEC)
    return d, [d.solve(m).V for m in MOVES]


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
    for move, V in zip(MOVES, expected):
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


def test_uploaded_file_downloads_byte_for_byte_and_converts(client, tc):
    mesh = upload_bracket(client)
    assert client.download_mesh(mesh["id"]) == BRACKET.read_bytes()
    msh = client.download_mesh(mesh["id"], file_format="msh")
    assert msh[:11] == b"$MeshFormat"  # tets + faces: written as Gmsh 2.2
    r = tc.get(f"/v1/meshes/{mesh['id']}/file", params={"format": "tetgen"})
    # TetGen holds neither the deck's named sets nor its CPS3 faces: refused, saying what would be lost
    assert r.status_code == 422 and err(r)["code"] == "lossy_write"
    assert {x["name"] for x in err(r)["details"]["losses"]} >= {"FIXED", "LOAD", "triangle"}


def test_tetgen_upload_needs_its_ele(tc):
    r = tc.post("/v1/meshes", files=[("file", ("beam.node", (DATA / "beam.node").read_bytes()))])
    assert r.status_code == 422 and err(r)["code"] == "missing_companion"


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


def _inp_bytes(points, tets, kind="C3D4"):
    lines = ["*NODE"] + [f"{i + 1}, {x}, {y}, {z}" for i, (x, y, z) in enumerate(points)]
    lines += [f"*ELEMENT, TYPE={kind}"]
    lines += [f"{e + 1}, " + ", ".join(str(int(v) + 1) for v in t) for e, t in enumerate(tets)]
    return ("\n".join(lines) + "\n").encode()


TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])


@pytest.mark.parametrize("name,data,code", [
    ("garbage.inp", b"\x00\x01 this is not an abaqus deck \xff" * 10, None),
    ("empty.msh", b"", None),
    ("inverted.inp", _inp_bytes(TET, [[0, 2, 1, 3]]), "inverted_input"),
    ("flat.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]]), [[0, 1, 2, 3]]),
     None),
    ("nan.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, float("nan")]]),
                           [[0, 1, 2, 3]]), "non_finite_coordinates"),
    ("badindex.inp", _inp_bytes(TET, [[0, 1, 2, 7]]), None),
    ("hexahedron20.inp", _inp_bytes(np.random.default_rng(0).random((20, 3)), [list(range(20))], kind="C3D20"),
     "unsupported_element"),
    ("twisted_hex.inp", _inp_bytes(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                                             [0.2, 0.2, 1], [0, 1, 1.0]]), [list(range(8))], kind="C3D8"),
     "inverted_input"),
    ("surface.xyz", b"1 2 3\n", "unknown_format"),
])
def test_malformed_uploads_are_typed_422(tc, name, data, code):
    r = tc.post("/v1/meshes", files=[("file", (name, data))])
    e = err(r)
    assert r.status_code == 422, e
    if code:
        assert e["code"] == code, e
    assert e["message"]
    assert tc.get("/v1/meshes").json() == []  # nothing stored


def test_malformed_json_arrays(tc):
    bad = [
        ({"vertices": [[0, 0], [1, 0]], "tetrahedra": [[0, 1, 2, 3]]}, "invalid_request"),
        ({"vertices": [[0, 0, 0], [1, 0]], "tetrahedra": [[0, 1, 2, 3]]}, "invalid_request"),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2]]}, "invalid_request"),
        ({"vertices": [], "tetrahedra": []}, None),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2, 9]]}, None),
        ({"vertices": TET.tolist(), "tetrahedra": [[0, 1, 2, 3]], "sets": {"a": [12]}},
         "index_out_of_range"),
        ({"vertices": "abc"}, "invalid_request"),
    ]
    for body, code in bad:
        r = tc.post("/v1/meshes/arrays", json=body)
        e = err(r)
        assert r.status_code == 422, (body, e)
        if code:
            assert e["code"] == code, e


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


def test_lru_budget_evicts_and_rebuilds_transparently(tmp_path, bracket_library):
    _, expected = bracket_library
    with running(tmp_path, cache_budget_mb=0.001) as tc:
        from service.client import Client

        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        a = c.create_session(mid, BRACKET_SPEC)
        b = c.create_session(mid, BRACKET_SPEC)
        assert c.session(a["id"])["status"] == "evicted"
        assert tc.get("/health").json()["evictions"] >= 1
        X, _ = c.deform(a["id"], MOVES[1])  # rebuilt on use
        np.testing.assert_allclose(X, expected[1], atol=1e-12)
        assert c.session(a["id"])["builds"] == 2
        assert c.session(b["id"])["status"] == "evicted"


def test_idle_sessions_are_swept(tmp_path):
    with running(tmp_path, session_ttl_s=60) as tc:
        from service.client import Client

        c = Client(http=tc)
        s = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)
        reg = tc.app.state.registry
        import time

        assert reg.sweep(now=time.time() + 30) == []
        assert reg.sweep(now=time.time() + 120) == [s["id"]]
        assert tc.get(f"/v1/sessions/{s['id']}").status_code == 404
    with running(tmp_path) as tc:  # and it stays gone after a restart
        assert tc.get(f"/v1/sessions/{s['id']}").status_code == 404


def test_restart_keeps_meshes_sessions_and_last_move(tmp_path, bracket_library):
    _, expected = bracket_library
    from service.client import Client

    with running(tmp_path) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        sid = c.create_session(mid, BRACKET_SPEC)["id"]
        c.deform(sid, MOVES[2])
    with running(tmp_path) as tc:
        c = Client(http=tc)
        assert c.session(sid)["status"] == "stored" and c.session(sid)["last_move"] == MOVES[2]
        np.testing.assert_allclose(c.positions(sid), expected[2], atol=1e-12)  # rebuilt
        X, _ = c.deform(sid, MOVES[0])
        np.testing.assert_allclose(X, expected[0], atol=1e-12)
        assert c.mesh(mid)["info"]["tetrahedra"] == 4228


def test_api_keys_isolate_tenants(tmp_path):
    from service.client import Client

    with running(tmp_path, api_keys="alpha,beta") as tc:
        r = tc.get("/v1/meshes")
        assert r.status_code == 401 and err(r)["code"] == "missing_api_key"
        r = tc.get("/v1/meshes", headers={"X-API-Key": "gamma"})
        assert r.status_code == 401 and err(r)["code"] == "invalid_api_key"
        a, b = Client(http=tc, api_key="alpha"), Client(http=tc, api_key="beta")
        mid = upload_bracket(a)["id"]
        sid = a.create_session(mid, BRACKET_SPEC)["id"]
        for call in (lambda: b.mesh(mid), lambda: b.session(sid), lambda: b.deform(sid, MOVES[0]),
                     lambda: b.delete_session(sid), lambda: b.create_session(mid, BRACKET_SPEC)):
            with pytest.raises(TetmorphError) as e:
                call()
            assert e.value.status == 404
        assert b.http.get("/v1/meshes", headers={"X-API-Key": "beta"}).json() == []
        assert len(a.http.get("/v1/sessions", headers={"Authorization": "Bearer alpha"}).json()) == 1
        assert tc.get("/health").status_code == 200  # liveness needs no key
    assert "alpha" not in "".join(p.read_text() for p in tmp_path.rglob("*.json"))


def test_limits(tmp_path):
    from service.client import Client

    with running(tmp_path, max_upload_mb=0.1) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
        assert r.status_code == 413 and err(r)["code"] == "payload_too_large"
        assert "bytes" in err(r)["message"]
    with running(tmp_path, max_elements=1000) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
        assert r.status_code == 422 and err(r)["code"] == "too_many_elements"
        assert "4228" in err(r)["message"]
    with running(tmp_path, max_sessions=1) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        c.create_session(mid, BRACKET_SPEC)
        r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
        assert r.status_code == 429 and err(r)["code"] == "session_limit"
    with running(tmp_path, rate_limit_per_s=0.5, rate_burst=3) as tc:
        codes = [tc.get("/v1/meshes").status_code for _ in range(4)]
        assert codes == [200, 200, 200, 429]
        r = tc.get("/v1/meshes")
        assert err(r)["code"] == "rate_limited" and int(r.headers["retry-after"]) >= 1


def test_http_errors_use_the_envelope(tc):
    r = tc.get("/v1/nowhere")
    assert r.status_code == 404 and err(r)["code"] == "not_found"
    r = tc.put("/v1/meshes")
    assert r.status_code == 405 and err(r)["code"] == "method_not_allowed"
    r = tc.post("/v1/sessions", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and err(r)["code"] == "invalid_request"
    r = tc.get("/v1/sessions/../../etc/passwd")
    assert r.status_code == 404


def test_tetrahedralize_closed_surface(client, tc, tmp_path):
    V, F = sphere_surface(2, 1.0)
    path = tmp_path / "ball.stl"
    meshio.write(path, meshio.Mesh(V, [("triangle", F)]))
    doc = client.tetrahedralize(path, edge_length_fac=0.15)
    info = doc["info"]
    assert info["tetrahedra"] > 100 and info["quality"]["min_volume"] > 0
    assert doc["tetrahedralization"]["surface_triangles"] == len(F)
    enclosed = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
    assert abs(info["quality"]["total_volume"] / enclosed - 1) < 0.01  # envelope 1e-3 of diag
    # the stored mesh deforms like any other
    spec = {"selections": {"s": {"box": {"min": [-2, -2, -2], "max": [2, 2, -0.8]}},
                           "n": {"box": {"min": [-2, -2, 0.8], "max": [2, 2, 2]}}},
            "fixed": ["s"], "handles": {"n": "n"}}
    s = client.create_session(doc["id"], spec)
    _, rep = client.deform(s["id"], {"handles": {"n": {"translation": [0, 0, 0.1]}}})
    assert rep["inverted_elements"] == 0
    # an open surface is refused, naming the defect
    meshio.write(path, meshio.Mesh(V, [("triangle", F[:-3])]))
    r = tc.post("/v1/tetrahedralize", files=[("file", ("open.stl", path.read_bytes()))])
    assert r.status_code == 422 and err(r)["code"] == "open_surface"


def test_websocket_latest_wins(client, tc, bracket_library):
    _, expected = bracket_library
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    moves = [{"handles": {"tip": {"translation": [0, 0, 0.2 * k]}}} for k in range(1, 40)]
    moves[-1] = MOVES[1]
    with tc.websocket_connect(f"/v1/sessions/{s['id']}/stream?dtype=float64") as ws:
        for k, m in enumerate(moves, 1):
            ws.send_text(json.dumps({"seq": k, "move": m}))
        seen, dropped = [], 0
        while not seen or seen[-1] != len(moves):
            X, head = decode_frame(ws.receive_bytes())
            seen.append(head["seq"])
            dropped += head["dropped"]
        ws.send_text(json.dumps({"seq": 99, "move": {"handles": {"zz": {}}}}))
        bad = ws.receive_json()
        assert bad["seq"] == 99 and bad["error"]["code"] == "invalid_spec"
    assert seen == sorted(seen) and len(seen) + dropped == len(moves)
    assert dropped > 0, seen  # 39 MOVEs sent at once cannot all be solved in turn
    np.testing.assert_allclose(X, expected[1], atol=1e-12)
    assert client.session(s["id"])["last_move"] == MOVES[1]


def test_websocket_refuses_unknown_session(tc):
    from starlette.websockets import WebSocketDisconnect

    with pytest.raises(WebSocketDisconnect) as e:
        with tc.websocket_connect("/v1/sessions/s_nope/stream") as ws:
            ws.receive_bytes()
    assert e.value.code == 4404


def test_demo_loads_at_startup(tmp_path):
    with running(tmp_path, demo=True) as tc:
        doc = tc.get("/v1/sessions/s_demo").json()
        assert doc["status"] == "ready" and doc["last_move"] is not None
        r = tc.post("/v1/sessions/s_demo/deform", json={"handles": {"tip": {"translation":
                                                                            [0, 0, 0.2]}}})
        assert r.status_code == 200 and r.json()["report"]["inverted_elements"] == 0
    with running(tmp_path, demo=True) as tc:  # idempotent across restarts
        assert len(tc.get("/v1/sessions").json()) == 1
    assert BEAM_SPEC["handles"] == {"tip": "tip"}


def test_concurrent_updates_serialize_per_session_and_run_across_sessions(tmp_path,
                                                                          bracket_library):
    import asyncio

    import httpx

    from service.app import create_app

    _, expected = bracket_library
    app = create_app(data_dir=tmp_path)

    async def scenario():
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as ac:
            up = await ac.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
            mid = up.json()["id"]
            sids = [(await ac.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}
                                   )).json()["id"] for _ in range(2)]
            calls = [ac.post(f"/v1/sessions/{sids[k % 2]}/deform", json=MOVES[k % 3],
                             params={"result": "binary"}) for k in range(12)]
            rs = await asyncio.gather(*calls)
            docs = [(await ac.get(f"/v1/sessions/{s}")).json() for s in sids]
            return rs, docs

    rs, docs = asyncio.run(scenario())
    assert [r.status_code for r in rs] == [200] * 12
    for k, r in enumerate(rs):  # every answer is its own MOVE's exact result
        np.testing.assert_allclose(decode_frame(r.content)[0], expected[k % 3], atol=1e-12)
    assert [d["updates"] for d in docs] == [6, 6]
    app.state.registry.close()


def test_tetrahedralize_leaves_no_file_behind(tmp_path, monkeypatch):
    from solver.io.tetrahedralize import TRACKED_SURFACE, tetrahedralize

    monkeypatch.chdir(tmp_path)
    V, F = sphere_surface(1, 1.0)
    tetrahedralize(V, F, edge_length_fac=0.3)
    assert not (tmp_path / TRACKED_SURFACE).exists()


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
    # consistent at rest, conflicting after a MOVE: that MOVE is refused, the session keeps its state
    ok = {**BRACKET_SPEC, "points": [{"name": "p", "vertices": [v]}], "conflicts": "reject"}
    s2 = client.create_session(mesh["id"], ok)
    X0, rep0 = client.deform(s2["id"], MOVES[0])
    assert rep0["redundant_constraints"][0]["name"] == "p"
    with pytest.raises(TetmorphError) as ex:
        client.deform(s2["id"], {**MOVES[0], "points": {"p": [0, 0, 0]}})
    assert ex.value.status == 422 and ex.value.code == "conflicting_constraints"
    np.testing.assert_array_equal(client.positions(s2["id"]), X0)


def test_feature_candidates_and_min_cut_region_over_http(client, tc):
    mesh = upload_bracket(client)
    r = tc.get(f"/v1/meshes/{mesh['id']}/features")
    assert r.status_code == 200
    kinds = [c["kind"] for c in r.json()]
    assert kinds.count("hole") == 1 and kinds.count("plane") == 6
    hole = next(c for c in tc.get(f"/v1/meshes/{mesh['id']}/features?ids=true").json()
                if c["kind"] == "hole")
    assert abs(hole["radius"] - 5) < 1e-6
    band = [{"box": {"min": [52, 2, -1], "max": [68, 18, 2]}, "boundary_only": True},
            {"box": {"min": [52, 2, 8], "max": [68, 18, 11]}, "boundary_only": True}]
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": band})
    assert r.status_code == 200
    assert sorted(r.json()["selection"]["ids"]) == sorted(hole["selection"]["ids"])
    # the returned selection is usable as a rigid feature in a session
    spec = {**BRACKET_SPEC, "selections": {**BRACKET_SPEC["selections"], "wall": r.json()["selection"]},
            "features": [{"selection": "wall", "mode": "rigid", "name": "bolt"}]}
    s = client.create_session(mesh["id"], spec)
    X, rep = client.deform(s["id"], MOVES[0])
    assert rep["constraint_residual_max"] < 1e-9
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": band[:1]})
    assert r.status_code == 422 and err(r)["code"] == "band_not_separating"
    r = tc.post(f"/v1/meshes/{mesh['id']}/feature-region", json={"band": [{"cube": 1}]})
    assert r.status_code == 422


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
                                                         back.cells) if c.type == "tetra"])
    np.testing.assert_allclose(per["per_element"]["scaled_jacobian"], tets)
    r = tc.get(f"/v1/sessions/{s['id']}/quality?metrics=beauty")
    assert r.status_code == 422 and err(r)["code"] == "unknown_metric"


def test_mixed_element_deck_over_rest(client, tc, tmp_path):
    """Hexahedra, wedges and pyramids: upload, morph, per-element quality (null for tet-only
    metrics), geometry for the viewer, and the Gmsh file back with only node lines changed."""
    mesh = client.upload_mesh(DATA / "mixed.msh")
    assert mesh["info"]["elements"] == 1113 and mesh["info"]["cell_types"]["wedge"] == 172
    spec = {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}}, "fixed": ["fix"],
            "handles": {"tip": "load"}}
    s = client.create_session(mesh["id"], spec)
    move = {"handles": {"tip": {"translation": [0, 0, 4], "rotation": {"axis": [0, 1, 0], "angle_deg": -15}}}}
    rep = tc.post(f"/v1/sessions/{s['id']}/deform?result=report&quality=full", json=move).json()["report"]
    assert rep["inverted_elements"] == 0 and rep["constraint_residual_max"] <= 1e-9
    assert sum(rep["quality"]["after"]["scaled_jacobian"]["histogram"]["counts"]) == 1113
    per = tc.get(f"/v1/sessions/{s['id']}/quality?metrics=scaled_jacobian,min_dihedral_deg").json()
    assert per["elements"] == 1113
    assert per["per_element"]["min_dihedral_deg"][797:] == [None] * (1113 - 797)
    assert all(v is not None for v in per["per_element"]["scaled_jacobian"])
    geo, head = decode_bundle(tc.get(f"/v1/meshes/{mesh['id']}/geometry").content)
    assert geo["T"].shape == (797 + 128 * 8 + 172 * 6 + 16 * 4, 4) and head["elements"] == 1113
    body = tc.get(f"/v1/sessions/{s['id']}/mesh?format=msh").content
    src = (DATA / "mixed.msh").read_bytes()
    assert body.split(b"$Nodes")[0] == src.split(b"$Nodes")[0]
    assert body.split(b"$EndNodes")[1] == src.split(b"$EndNodes")[1]
