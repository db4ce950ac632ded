"""A real server closes a connection whose request head or body stops or drips, and still takes a slow, steady body.

The limits follow ``TETMORPH_HEAD_TIMEOUT_S`` (service/http_protocol.py): a head not complete
within that long; no byte of the body for that long, or, that long after the head, an average
below ``MIN_BODY_RATE``. Each case runs on both of uvicorn's HTTP/1.1 parsers
(``TETMORPH_HTTP_IMPL``): httptools, the default, and h11.
"""

from __future__ import annotations

import json
import os
import socket
import time

import httpx
import pytest

from service.http_protocol import MIN_BODY_RATE
from service.process import free_port, serve_process

LIMIT_S = 1.5
BODY = json.dumps({"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "tetrahedra": [[0, 1, 2, 3]],
                   "name": "x" * 150}).encode()


@pytest.fixture(scope="module", params=["httptools", "h11", "without-httptools"])
def server(tmp_path_factory, request):
    """A server on httptools, on h11 by the setting, or on h11 because httptools cannot be imported."""
    port = free_port()
    env = {"TETMORPH_HEAD_TIMEOUT_S": str(LIMIT_S)}
    if request.param == "without-httptools":  # uvicorn falls back to h11, as on an install without it
        shim = tmp_path_factory.mktemp("shim")
        (shim / "httptools.py").write_text("raise ImportError('httptools is hidden by the test')\n")
        env["PYTHONPATH"] = os.pathsep.join([str(shim), *filter(None, [os.environ.get("PYTHONPATH")])])
    else:
        env["TETMORPH_HTTP_IMPL"] = request.param
    with serve_process(tmp_path_factory.mktemp("slow"), port, env) as (url, _):
        yield port, url


def _head(length: int) -> bytes:
    return (f"POST /v1/meshes/arrays HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
            f"Content-Length: {length}\r\n\r\n").encode()


def _send_paced(port: int, chunks: list[bytes], pause_s: float, length: int) -> tuple[float | None, bytes]:
    """Send the head, then the chunks ``pause_s`` apart; (seconds until the server closed, or None; its answer)."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(_head(length))
        t0 = time.monotonic()
        for chunk in chunks:
            try:
                sock.sendall(chunk)
            except OSError:
                return time.monotonic() - t0, b""
            sock.settimeout(pause_s)
            try:
                got = sock.recv(65536)
                if got == b"":
                    return time.monotonic() - t0, b""
                return None, got  # answered before the body ended: not what these cases send
            except TimeoutError:
                pass
            except ConnectionResetError:  # closed with input unread: the kernel answers with a reset
                return time.monotonic() - t0, b""
        sock.settimeout(10)
        answer = b""
        try:
            while b"\r\n\r\n" not in answer:
                part = sock.recv(65536)
                if not part:
                    break
                answer += part
        except OSError:
            pass
        return (time.monotonic() - t0 if not answer else None), answer


def test_a_body_that_stops_after_the_head_is_cut_off(server):
    port, url = server
    closed_at, _ = _send_paced(port, [b"{"] + [b""] * 40, 0.2, len(BODY))  # then nothing, for up to 8 s
    assert closed_at is not None and LIMIT_S - 0.2 <= closed_at <= LIMIT_S + 2.5, closed_at
    assert httpx.get(url + "/health", timeout=10).status_code == 200


def test_a_dripping_body_is_cut_off(server):
    port, url = server
    drip = [BODY[k:k + 1] for k in range(len(BODY))]  # a byte every 0.3 s: never idle, far below the pace
    closed_at, _ = _send_paced(port, drip[:30], 0.3, len(BODY))
    assert closed_at is not None and LIMIT_S - 0.2 <= closed_at <= LIMIT_S + 2.5, closed_at
    assert httpx.get(url + "/health", timeout=10).status_code == 200


def test_a_slow_steady_body_is_answered(server):
    port, _ = server
    body = BODY + b" " * 6000  # JSON allows the trailing blanks
    per = int(4 * MIN_BODY_RATE * 0.4)  # four times the slowest pace, over about 4 s
    chunks = [body[k:k + per] for k in range(0, len(body), per)]
    closed_at, answer = _send_paced(port, chunks, 0.4, len(body))
    assert closed_at is None and answer.startswith(b"HTTP/1.1 201"), (closed_at, answer[:200])


def test_a_dripping_head_is_cut_off(server):
    """A byte of the request line and headers every 0.2 s (at most 8 s): closed once the head takes the limit."""
    port, url = server
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        t0 = time.monotonic()
        closed_at = None
        for ch in "GET /health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + "a" * 40:
            try:
                sock.sendall(ch.encode())
                sock.settimeout(0.2)
                if sock.recv(1) == b"":
                    closed_at = time.monotonic() - t0
                    break
            except TimeoutError:
                pass
            except OSError:
                closed_at = time.monotonic() - t0
                break
        assert closed_at is not None and LIMIT_S - 0.2 <= closed_at <= LIMIT_S + 2.5, closed_at
    assert httpx.get(url + "/health", timeout=10).status_code == 200
