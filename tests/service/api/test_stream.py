"""The WebSocket stream of MOVEs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from service.binary import decode_frame

from ..conftest import BRACKET_SPEC, MOVES, err, running, upload_bracket


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


def test_a_session_deleted_while_streamed_stays_deleted(tmp_path):
    from starlette.websockets import WebSocketDisconnect

    from service.client import Client

    from ..conftest import running

    with running(tmp_path / "data") as tc:
        c = Client(http=tc)
        sid = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)["id"]
        with pytest.raises(WebSocketDisconnect) as e:
            with tc.websocket_connect(f"/v1/sessions/{sid}/stream") as ws:
                ws.send_text(json.dumps({"seq": 1, "move": MOVES[0]}))
                decode_frame(ws.receive_bytes())
                assert tc.delete(f"/v1/sessions/{sid}").status_code == 204
                ws.send_text(json.dumps({"seq": 2, "move": MOVES[1]}))
                ws.receive_bytes()
        assert e.value.code == 4404
        assert tc.get(f"/v1/sessions/{sid}").status_code == 404
        folder = tc.app.state.registry.store.sessions_dir
    assert not (folder / f"{sid}.json").exists(), "the stream wrote the deleted session back"
    with running(tmp_path / "data") as tc:  # and a restart does not list it
        assert tc.get("/v1/sessions").json() == []


def test_websocket_frames_are_strict_and_leave_the_session_unchanged(client, tc):
    from starlette.websockets import WebSocketDisconnect

    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    X0, _ = client.deform(s["id"], MOVES[0])
    bad_frames = [
        "not json", "[1, 2]", json.dumps({"seq": 12}),  # no move: an error, not a reset
        json.dumps({"seq": 1, "move": MOVES[1], "extra": 1}),
        json.dumps({"seq": 1, "move": {"handles": {"tip": {"translation": [True, False, 0]}}}}),
        json.dumps({"seq": 1, "move": {"handles": {"tip": {"translation": ["1", "0", "0"]}}}}),
        json.dumps({"seq": 1, "move": {"handles": {"tip": {"rotation": {"axis": [1, 0, 0], "angle_deg": 1e300},
                                                            "scale": 1e300}}}}),
        "[" * 100_000 + "]" * 100_000,  # deep nesting
        '{"seq": 1, "move": {"handles": {"tip\\ud800": {"translation": [1, 0, 0]}}}}',  # not valid Unicode
    ]
    with tc.websocket_connect(f"/v1/sessions/{s['id']}/stream?dtype=float64") as ws:
        for text in bad_frames:
            ws.send_text(text)
            msg = ws.receive_json()
            assert msg["error"]["code"] in ("invalid_message",), msg
        ws.send_text(json.dumps({"seq": 5, "move": MOVES[0]}))  # the stream still works
        X, head = decode_frame(ws.receive_bytes())
        assert head["seq"] == 5 and head["report"]["finite"] is True
    np.testing.assert_array_equal(client.positions(s["id"]), X0)
    assert client.session(s["id"])["last_move"] == MOVES[0]
    # a frame over the size limit closes the stream with 1009 and a reason
    with running(tc.app.state.settings.data_dir, max_frame_kb=1) as tc2:
        with tc2.websocket_connect(f"/v1/sessions/{s['id']}/stream") as ws:
            ws.send_text(json.dumps({"seq": 1, "move": MOVES[0], "pad": "x" * 4000}))
            with pytest.raises(WebSocketDisconnect) as e:
                ws.receive_bytes()
        assert e.value.code == 1009 and "limit" in e.value.reason


def test_websocket_rejections_say_why(tmp_path):
    from starlette.websockets import WebSocketDisconnect

    with running(tmp_path, api_keys="alpha", max_connections_per_key=1) as tc:
        from service.client import Client

        c = Client(http=tc, api_key="alpha")
        sid = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)["id"]
        for url, code in ((f"/v1/sessions/{sid}/stream", 4401), (f"/v1/sessions/{sid}/stream?api_key=beta", 4401),
                          ("/v1/sessions/s_nope/stream?api_key=alpha", 4404)):
            with pytest.raises(WebSocketDisconnect) as e:
                with tc.websocket_connect(url) as ws:
                    ws.receive_bytes()
            assert e.value.code == code and e.value.reason, (url, e.value.code)
        with tc.websocket_connect(f"/v1/sessions/{sid}/stream?api_key=alpha") as ws:
            with pytest.raises(WebSocketDisconnect) as e:  # a second stream of the same key: over the limit
                with tc.websocket_connect(f"/v1/sessions/{sid}/stream?api_key=alpha") as ws2:
                    ws2.receive_bytes()
            assert e.value.code == 4429 and "open streams" in e.value.reason
            ws.send_text(json.dumps({"seq": 1, "move": MOVES[0]}))
            assert decode_frame(ws.receive_bytes())[1]["seq"] == 1
        r = tc.get("/v1/meshes?api_key=alpha")  # the query key is for the WebSocket upgrade only
        assert r.status_code == 401 and err(r)["code"] == "missing_api_key"


def test_boundary_frames_come_first_and_match_the_full_frame(client, tc, bracket_library):
    d, expected = bracket_library
    mesh = upload_bracket(client)
    s = client.create_session(mesh["id"], BRACKET_SPEC)
    B = d.mesh.boundary
    url = f"/v1/sessions/{s['id']}/stream?dtype=float64&frames=boundary"
    with tc.websocket_connect(url) as ws:
        for k, m in enumerate(MOVES, 1):  # one at a time: each gets both frames
            ws.send_text(json.dumps({"seq": k, "move": m}))
            Xb, hb = decode_frame(ws.receive_bytes())
            Xf, hf = decode_frame(ws.receive_bytes())
            assert (hb["frame"], hf["frame"]) == ("boundary", "full") and hb["seq"] == hf["seq"] == k
            assert Xb.shape == (int(B.sum()), 3) and "report" not in hb and "report" in hf
            np.testing.assert_array_equal(Xb, Xf[B])  # the boundary frame is already final
            np.testing.assert_allclose(Xf, expected[k - 1], atol=1e-12)
        # a burst: superseded MOVEs may get their boundary frame, never a full frame; the last one ends full
        burst = [{"handles": {"tip": {"translation": [0, 0, 0.2 * j]}}} for j in range(1, 30)]
        for j, m in enumerate(burst, 100):
            ws.send_text(json.dumps({"seq": j, "move": m}))
        full = []
        while not full or full[-1] != 100 + len(burst) - 1:
            _, h = decode_frame(ws.receive_bytes())
            if h["frame"] == "full":
                full.append(h["seq"])
    assert full == sorted(full) and len(full) < len(burst)
    assert client.session(s["id"])["last_move"] == burst[-1]


@pytest.mark.parametrize("query, name, allowed", [
    ("kind=velocity", "kind", ("positions", "displacements")),
    ("dtype=float16", "dtype", ("float32", "float64")),
    ("frames=partial", "frames", ("full", "boundary")),
])
def test_an_invalid_stream_parameter_closes_with_4422_naming_it_and_the_allowed_values(client, tc, query, name,
                                                                                       allowed):
    from starlette.websockets import WebSocketDisconnect

    s = client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)
    with pytest.raises(WebSocketDisconnect) as e:
        with tc.websocket_connect(f"/v1/sessions/{s['id']}/stream?{query}") as ws:  # accepted, then closed
            ws.receive_bytes()
    assert e.value.code == 4422, (e.value.code, e.value.reason)
    assert name in e.value.reason and all(a in e.value.reason for a in allowed), e.value.reason
