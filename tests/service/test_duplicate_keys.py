"""A JSON body or stream frame that names a key twice in one object is refused, at any depth.

JSON parsers keep the last of two equal keys (Python's, the browser's) or the first (others):
a strict document must not depend on which, so the service answers 422 ``duplicate_key`` naming
the key and where it is, and nothing is changed.
"""

from __future__ import annotations

import json

import pytest

from .conftest import BRACKET_SPEC, err, upload_bracket

JSON = {"content-type": "application/json"}


@pytest.fixture
def sid(client):
    return client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)["id"]


@pytest.mark.parametrize("body, path, key", [
    ('{"handles": {"tip": {"translation": [0, 0, 1], "translation": [0, 0, 9]}}}',
     "handles.tip.translation", "translation"),
    ('{"handles": {"tip": {"translation": [0, 0, 1], "\\u0074ranslation": [0, 0, 9]}}}',  # the same key, escaped
     "handles.tip.translation", "translation"),
    ('{"handles": {"tip": {"translation": [0, 0, 1]}}, "handles": {}}', "handles", "handles"),
])
def test_a_move_naming_a_key_twice_answers_422_and_changes_nothing(tc, sid, body, path, key):
    before = tc.get(f"/v1/sessions/{sid}").json()
    r = tc.post(f"/v1/sessions/{sid}/deform?result=report", content=body, headers=JSON)
    e = err(r)
    assert r.status_code == 422 and e["code"] == "duplicate_key", e
    assert e["details"]["key"] == key and e["details"]["field"] == path
    assert repr(key) in e["message"] and path in e["message"]
    after = tc.get(f"/v1/sessions/{sid}").json()
    assert after["version"] == before["version"] and after["last_move"] == before["last_move"]


def test_a_spec_naming_a_key_twice_creates_no_session(tc, client):
    mid = upload_bracket(client)["id"]
    spec = json.dumps(BRACKET_SPEC)[:-1] + ', "fixed": ["tip"]}'  # "fixed" twice at the SPEC's top
    r = tc.post("/v1/sessions", content=f'{{"mesh_id": "{mid}", "spec": {spec}}}', headers=JSON)
    e = err(r)
    assert r.status_code == 422 and e["code"] == "duplicate_key" and e["details"]["field"] == "spec.fixed", e
    assert tc.get("/v1/sessions").json() == []


def test_a_duplicate_key_inside_a_list_is_named_by_its_index(tc, sid):
    body = ('{"presets": [{"name": "a", "move": {}}, '
            '{"name": "b", "move": {"handles": {"tip": {"scale": 1.1, "scale": 2}}}}]}')
    r = tc.patch(f"/v1/sessions/{sid}", content=body, headers=JSON)
    e = err(r)
    assert r.status_code == 422 and e["details"]["field"] == "presets.1.move.handles.tip.scale", e
    assert tc.get(f"/v1/sessions/{sid}").json()["presets"] == []


def test_equal_keys_in_different_objects_are_fine(tc, sid):
    body = '{"handles": {"tip": {"translation": [0, 0, 1], "pivot": {"translation": 1}}}}'
    r = tc.post(f"/v1/sessions/{sid}/deform?result=report", content=body, headers=JSON)
    assert err(r)["code"] != "duplicate_key"  # whatever else is wrong with it, no key repeats in one object
    ok = '{"handles": {"tip": {"translation": [0, 0, 1]}}}'
    assert tc.post(f"/v1/sessions/{sid}/deform?result=report", content=ok, headers=JSON).status_code == 200


def test_a_stream_frame_naming_a_key_twice_is_answered_with_an_error_frame(tc, sid):
    with tc.websocket_connect(f"/v1/sessions/{sid}/stream") as ws:
        ws.send_text('{"seq": 3, "move": {"handles": {"tip": {"translation": [0, 0, 1]}}}, "seq": 4}')
        doc = ws.receive_json()
    assert doc["error"]["code"] == "duplicate_key" and doc["error"]["details"]["field"] == "seq", doc
    assert tc.get(f"/v1/sessions/{sid}").json()["last_move"] is None
