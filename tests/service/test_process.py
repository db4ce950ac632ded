"""Against a real ``tetmorph serve`` (uvicorn) on a loopback port, restarted mid-session."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator

import httpx
import numpy as np
import pytest
from websockets.sync.client import connect

from service.binary import decode_frame
from service.client import Client
from service.process import free_port, serve_process
from solver import read_mesh
from solver.deform.deformer import precompute

from .conftest import BRACKET, BRACKET_SPEC

pytestmark = pytest.mark.slow  # real server processes: make test, not make check

MOVES = [{"handles": {"tip": {"translation": [0.0, 3.0 * k, 1.0]}}} for k in range(4)]


@contextlib.contextmanager
def server(data_dir, port: int, *env_pairs: tuple[str, str]) -> Iterator[str]:
    with serve_process(data_dir, port, dict(env_pairs)) as (url, _):
        yield url


@pytest.fixture(scope="module")
def expected():
    d = precompute(read_mesh(BRACKET), BRACKET_SPEC)
    return [d.solve(m).V for m in MOVES]


def test_real_server_restart_and_stream(tmp_path, expected):
    port = free_port()
    with server(tmp_path, port) as url, Client(url) as c:
        mid = c.upload_mesh(BRACKET)["id"]
        sid = c.create_session(mid, BRACKET_SPEC)["id"]
        for m, V in zip(MOVES[:2], expected[:2], strict=True):
            X, rep = c.deform(sid, m)
            np.testing.assert_allclose(X, V, atol=1e-12)
        c.download_result(sid, tmp_path / "before.inp")
    with server(tmp_path, port) as url, Client(url) as c:  # same data dir, new process
        doc = c.session(sid)
        assert doc["status"] == "stored" and doc["last_move"] == MOVES[1]
        c.download_result(sid, tmp_path / "after.inp")
        assert (tmp_path / "after.inp").read_bytes() == (tmp_path / "before.inp").read_bytes()
        X, _ = c.deform(sid, MOVES[2])
        np.testing.assert_allclose(X, expected[2], atol=1e-12)
        # WebSocket over the wire: a burst of MOVEs, the last one always answered
        ws_url = url.replace("http", "ws") + f"/v1/sessions/{sid}/stream?dtype=float64"
        with connect(ws_url, max_size=None) as ws:
            burst = [MOVES[k % 3] for k in range(30)] + [MOVES[3]]
            for k, m in enumerate(burst, 1):
                ws.send(json.dumps({"seq": k, "move": m}))
            seqs, dropped = [], 0
            while not seqs or seqs[-1] != len(burst):
                X, head = decode_frame(ws.recv(timeout=30))
                seqs.append(head["seq"])
                dropped += head["dropped"]
        assert seqs == sorted(seqs) and len(seqs) + dropped == len(burst)
        np.testing.assert_allclose(X, expected[3], atol=1e-12)


def test_real_server_api_keys_from_environment(tmp_path):
    port = free_port()
    with server(tmp_path, port, ("TETMORPH_API_KEYS", "k1,k2")) as url:
        assert httpx.get(url + "/v1/meshes").status_code == 401
        with Client(url, api_key="k1") as a, Client(url, api_key="k2") as b:
            mid = a.upload_mesh(BRACKET)["id"]
            assert httpx.get(f"{url}/v1/meshes/{mid}", headers={"X-API-Key": "k2"}
                             ).status_code == 404
            assert [m["id"] for m in a.http.get("/v1/meshes", headers=a.headers).json()] == [mid]
            assert b.http.get("/v1/meshes", headers=b.headers).json() == []


def test_stream_refusals_reach_a_real_client_as_close_codes(tmp_path):
    """Over the wire, not only in the test client: accept, then close with the documented code and a reason."""
    from websockets.exceptions import ConnectionClosed

    port = free_port()
    with server(tmp_path, port, ("TETMORPH_API_KEYS", "k1"), ("TETMORPH_MAX_CONNECTIONS_PER_KEY", "1")) as url:
        with Client(url, api_key="k1") as c:
            sid = c.create_session(c.upload_mesh(BRACKET)["id"], BRACKET_SPEC)["id"]
        ws_url = url.replace("http", "ws") + "/v1/sessions/{}/stream"
        for path, code in ((ws_url.format(sid), 4401), (ws_url.format(sid) + "?api_key=nope", 4401),
                           (ws_url.format("s_nope") + "?api_key=k1", 4404)):
            with connect(path) as ws, pytest.raises(ConnectionClosed) as e:
                ws.recv(timeout=10)
            assert e.value.rcvd is not None and e.value.rcvd.code == code and e.value.rcvd.reason, path
        with connect(ws_url.format(sid) + "?api_key=k1") as first:
            with connect(ws_url.format(sid) + "?api_key=k1") as ws, pytest.raises(ConnectionClosed) as e:
                ws.recv(timeout=10)
            assert e.value.rcvd.code == 4429
            first.send(json.dumps({"seq": 1, "move": MOVES[1]}))
            decode_frame(first.recv(timeout=30))  # the first stream still serves


def test_a_page_of_another_origin_cannot_open_a_stream(tmp_path):
    """A browser sends Origin with the handshake: another site's page is closed with 4403, the service's
    own page and a listed origin are served, and a client that sends no Origin is not affected."""
    from websockets.exceptions import ConnectionClosed

    port = free_port()
    with server(tmp_path, port, ("TETMORPH_ALLOWED_ORIGINS", "https://cae.example:8443")) as url:
        with Client(url) as c:
            sid = c.create_session(c.upload_mesh(BRACKET)["id"], BRACKET_SPEC)["id"]
        path = url.replace("http", "ws") + f"/v1/sessions/{sid}/stream"
        for origin in ("http://evil.example", f"http://127.0.0.1:{port + 1}", "null"):
            with connect(path, origin=origin) as ws, pytest.raises(ConnectionClosed) as e:
                ws.recv(timeout=10)
            assert e.value.rcvd is not None and e.value.rcvd.code == 4403 and "origin" in e.value.rcvd.reason
        for origin in (url, "https://cae.example:8443", None):
            with connect(path, origin=origin) as ws:
                ws.send(json.dumps({"seq": 1, "move": MOVES[1]}))
                assert decode_frame(ws.recv(timeout=30))  # served
