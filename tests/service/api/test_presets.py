"""Named MOVE presets kept with a session: PATCH /v1/sessions/{id}, answered in the session document.

They are not the session's morph state: saving them leaves the version, the last MOVE and the
positions alone, and a MOVE's commit (or a reset) leaves them alone.
"""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest

from service.models.session import PRESETS_MAX, PRESETS_MAX_BYTES

from ..conftest import BRACKET_SPEC, MOVES, err, running, upload_bracket

PRESETS = [{"name": "lift 4", "move": MOVES[0]}, {"name": "twist", "move": MOVES[1]}]


def patch(tc, sid, body):
    return tc.patch(f"/v1/sessions/{sid}", json=body)


def stored_presets(data_dir, sid):
    """The presets file of a session in the data directory (None when there is none)."""
    p = data_dir / "sessions" / "presets" / f"{sid}.json"
    return json.loads(p.read_text()) if p.exists() else None


def test_presets_are_replaced_by_patch_and_leave_the_morph_state_alone(client, tc, bracket_library):
    _, want = bracket_library
    s = client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)
    assert s["presets"] == [] and client.session(s["id"])["presets"] == []
    client.deform(s["id"], MOVES[2])
    before = client.session(s["id"])
    r = patch(tc, s["id"], {"presets": PRESETS})
    assert r.status_code == 200
    doc = r.json()
    assert doc["presets"] == PRESETS
    for k in ("version", "last_move", "updates", "builds", "status"):
        assert doc[k] == before[k], k  # the morph state is untouched
    np.testing.assert_array_equal(client.positions(s["id"]), want[2])
    assert client.session(s["id"])["presets"] == PRESETS
    assert [x["presets"] for x in tc.get("/v1/sessions").json()] == [PRESETS]
    # applying a preset is a deform with its MOVE; the commit and a reset keep the presets
    X, _ = client.deform(s["id"], doc["presets"][1]["move"])
    np.testing.assert_allclose(X, want[1], rtol=0, atol=1e-12)
    after = client.session(s["id"])
    assert after["version"] == before["version"] + 1 and after["presets"] == PRESETS
    assert client.reset(s["id"])["presets"] == PRESETS
    assert client.session(s["id"])["presets"] == PRESETS
    # the list is replaced as a whole (the client's method), and may be emptied
    one = client.set_presets(s["id"], [{"name": "ø 5 mm ↑", "move": {"handles": {"tip": {"scale": 1.1}}}}])
    assert [p["name"] for p in one["presets"]] == ["ø 5 mm ↑"] and one["presets"][0]["move"]["handles"]["tip"] == {
        "scale": 1.1}
    assert client.set_presets(s["id"], [])["presets"] == []
    assert client.session(s["id"])["presets"] == []
    e = err(patch(tc, "s_0000000000000000", {"presets": PRESETS}))
    assert e["code"] == "session_not_found"


def test_bad_presets_are_422_naming_the_field_and_store_nothing(client, tc):
    s = client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)
    sid = s["id"]
    data = tc.app.state.settings.data_dir
    assert patch(tc, sid, {"presets": PRESETS}).status_code == 200
    kept = stored_presets(data, sid)
    ok = {"name": "ok", "move": MOVES[0]}
    big_points = {f"p{k}": [0.5, 0.5, 0.5] for k in range(PRESETS_MAX_BYTES // 20)}
    bad = [
        ({"presets": [ok, {"name": "b", "move": {"handles": {"tip": {"translation": [1, 2]}}}}]},
         "presets.1.move.handles.tip.translation"),
        ({"presets": [ok, {"name": "b", "move": {"handles": {"tip": {"scale": -1}}}}]},
         "presets.1.move.handles.tip.scale"),
        ({"presets": [{"name": "b", "move": {"handles": {"tip": {"translation": [True, 0, 0]}}}}]}, "translation"),
        ({"presets": [{"name": "b", "move": {"rotate": 1}}]}, "presets.0.move.rotate"),
        ({"presets": [{"name": "b", "move": "up"}]}, "presets.0.move"),
        ({"presets": [{"name": "b"}]}, "presets.0.move"),
        ({"presets": [ok, {"name": "ok", "move": MOVES[1]}]}, "presets[1].name 'ok' is already the name of presets[0]"),
        ({"presets": [{"name": "", "move": MOVES[0]}]}, "presets.0.name"),
        ({"presets": [{"name": "   ", "move": MOVES[0]}]}, "presets.0.name"),
        ({"presets": [{"name": "x" * 65, "move": MOVES[0]}]}, "presets.0.name"),
        ({"presets": [{"name": "x" * 5_000_000, "move": MOVES[0]}]}, "presets.0.name"),
        ({"presets": [{"name": 7, "move": MOVES[0]}]}, "presets.0.name"),
        ({"presets": [{"name": "b", "move": MOVES[0], "colour": "red"}]}, "presets.0.colour"),
        ({"presets": [{"name": f"p{k}", "move": MOVES[0]} for k in range(PRESETS_MAX + 1)]}, "presets"),
        ({"presets": [{"name": "big", "move": {"points": big_points}}]}, f"at most {PRESETS_MAX_BYTES}"),
        ({"presets": {"lift": MOVES[0]}}, "presets"),
        ({"presets": None}, "presets"),
        ({}, "presets"),
        ({"presets": [], "notes": {}}, "notes"),
        ([ok], "body"),
    ]
    for body, word in bad:
        r = patch(tc, sid, body)
        e = err(r)
        assert r.status_code == 422 and e["code"] == "invalid_request", (body if len(str(body)) < 200 else word, e)
        assert word in e["message"], (word, e["message"][:300])
        assert stored_presets(data, sid) == kept and client.session(sid)["presets"] == PRESETS
    # not JSON, non-finite numbers, deep nesting: a 4xx, never a 5xx, and nothing stored
    for raw in (b"{not json", b'{"presets": [{"name": "n", "move": {"handles": {"tip": {"scale": NaN}}}}]}',
                b'{"presets": [{"name": "n", "move": {"handles": {"tip": {"translation": [1e400, 0, 0]}}}}]}',
                b'{"presets": [{"name": "n", "move": ' + b"[" * 100_000 + b"]" * 100_000 + b"}]}",
                b'{"presets": ' + b'{"a": ' * 50_000 + b"1" + b"}" * 50_000 + b"}"):
        r = tc.patch(f"/v1/sessions/{sid}", content=raw, headers={"content-type": "application/json"})
        assert 400 <= r.status_code < 500 and err(r)["code"] in ("invalid_request", "bad_request"), r.text[:300]
        assert stored_presets(data, sid) == kept
    assert client.session(sid)["presets"] == PRESETS and client.session(sid)["version"] == s["version"]
    # the limits themselves are accepted
    edge = [{"name": f"{k:0>64}", "move": {}} for k in range(PRESETS_MAX)]
    assert [p["name"] for p in patch(tc, sid, {"presets": edge}).json()["presets"]] == [p["name"] for p in edge]


def test_presets_persist_across_a_restart_and_old_records_have_none(tmp_path, bracket_library):
    _, want = bracket_library
    data = tmp_path / "data"
    with running(data) as tc:
        from service.client import Client

        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        a = c.create_session(mid, BRACKET_SPEC)["id"]
        b = c.create_session(mid, BRACKET_SPEC)["id"]
        c.set_presets(a, PRESETS)
        c.deform(a, MOVES[2])
    record = json.loads((data / "sessions" / f"{a}.json").read_text())
    assert "presets" not in record  # kept apart from the versioned record
    assert stored_presets(data, b) is None  # as for every record written before presets existed
    with running(data) as tc:
        c = Client(http=tc)
        doc = c.session(a)
        assert doc["presets"] == PRESETS and doc["last_move"] == MOVES[2] and doc["status"] == "stored"
        X, _ = c.deform(a, doc["presets"][0]["move"])  # rebuilt on use, at the preset's MOVE
        np.testing.assert_allclose(X, want[0], rtol=0, atol=1e-12)
        assert c.session(b)["presets"] == []
        assert c.set_presets(b, PRESETS[:1])["presets"] == PRESETS[:1]
        c.delete_session(a)
        assert stored_presets(data, a) is None  # deleted with the session
    with running(data) as tc:
        assert [s["presets"] for s in tc.get("/v1/sessions").json()] == [PRESETS[:1]]


def test_a_patch_does_not_wait_for_a_move_being_solved_nor_cross_keys(tmp_path):
    with running(tmp_path, api_keys="alpha,beta") as tc:
        from service.client import Client

        alpha, beta = Client(http=tc, api_key="alpha"), Client(http=tc, api_key="beta")
        sid = alpha.create_session(upload_bracket(alpha)["id"], BRACKET_SPEC)["id"]
        s = tc.app.state.registry.sessions[sid]
        tc.portal.call(s.lock.acquire)  # as while a MOVE of the session is solved
        out: dict = {}
        t = threading.Thread(target=lambda: out.setdefault("doc", alpha.set_presets(sid, PRESETS)))
        t.start()
        t.join(30)
        answered = not t.is_alive()
        tc.portal.call(s.lock.release)
        t.join()
        assert answered and out["doc"]["presets"] == PRESETS and out["doc"]["version"] == 0
        with pytest.raises(Exception) as e:
            beta.set_presets(sid, [])  # another key's session: not found, and unchanged
        assert e.value.code == "session_not_found"
        assert alpha.session(sid)["presets"] == PRESETS


def test_openapi_documents_the_patch(tc):
    doc = tc.app.openapi()
    op = doc["paths"]["/v1/sessions/{session_id}"]["patch"]
    assert op["tags"] == ["sessions"]
    assert op["requestBody"]["content"]["application/json"]["schema"]["$ref"].endswith("/SessionPatch")
    assert {"200", "401", "404", "410", "413", "422", "429"} <= set(op["responses"])
    assert op["responses"]["200"]["content"]["application/json"]["schema"]["$ref"].endswith("/SessionDoc")
    schemas = doc["components"]["schemas"]
    assert schemas["Preset"]["properties"]["move"]["$ref"].endswith("/Move")  # the deform route's MOVE
    assert "presets" in schemas["SessionDoc"]["properties"]
