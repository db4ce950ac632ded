"""A request names at most one API key: credentials that disagree are refused, never resolved to one of them."""

from __future__ import annotations

import json

import pytest

from .conftest import BRACKET_SPEC, err, running, upload_bracket


@pytest.fixture
def keyed(tmp_path):
    with running(tmp_path, api_keys="alpha,beta") as tc:
        yield tc


@pytest.mark.parametrize("headers", [
    [("X-API-Key", "alpha"), ("X-API-Key", "beta")],
    [("X-API-Key", "alpha"), ("Authorization", "Bearer beta")],
    [("Authorization", "Bearer alpha"), ("Authorization", "Bearer beta")],
    [("X-API-Key", "alpha"), ("X-API-Key", "nope")],  # one valid, one unknown: not "the first wins" either
], ids=["two-x-api-key", "x-api-key-and-bearer", "two-bearer", "valid-and-unknown"])
def test_credentials_naming_different_keys_answer_400(keyed, headers):
    r = keyed.get("/v1/meshes", headers=headers)
    e = err(r)
    assert r.status_code == 400 and e["code"] == "conflicting_credentials", e
    names = {name for name, _ in headers}
    assert all(n in e["message"] for n in names) and sorted(e["details"]["headers"]) == sorted(names)
    text = r.text
    for _, value in headers:  # the keys are never echoed
        assert value.removeprefix("Bearer ") not in text


def test_the_same_key_sent_twice_is_accepted(keyed):
    for headers in ([("X-API-Key", "alpha"), ("X-API-Key", "alpha")],
                    [("X-API-Key", "alpha"), ("Authorization", "Bearer alpha")]):
        assert keyed.get("/v1/meshes", headers=headers).status_code == 200, headers


def test_a_stream_whose_header_and_query_keys_differ_is_closed_with_4400(tmp_path):
    from starlette.websockets import WebSocketDisconnect

    from service.client import Client

    with running(tmp_path, api_keys="alpha,beta") as tc:
        c = Client(http=tc, api_key="alpha")
        sid = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)["id"]
        with pytest.raises(WebSocketDisconnect) as e:
            with tc.websocket_connect(f"/v1/sessions/{sid}/stream?api_key=beta",
                                      headers={"X-API-Key": "alpha"}) as ws:
                ws.send_text(json.dumps({"seq": 1, "move": {}}))  # served, were either key taken
                ws.receive_bytes()
        assert e.value.code == 4400 and "api_key" in e.value.reason and "beta" not in e.value.reason
