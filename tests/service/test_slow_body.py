"""A real server closes a connection whose request body stops or drips, and still takes a slow, steady body.

The limits follow ``TETMORPH_HEAD_TIMEOUT_S`` (service/http_protocol.py): no byte of the body
for that long, or, that long after the head, an average below ``MIN_BODY_RATE``.
"""

from __future__ import annotations

import json
import socket
import time

import httpx
import pytest

from service.http_protocol import MIN_BODY_RATE
from service.process import free_port, serve_process

LIMIT_S = 1.5
BODY = json.dumps({"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "tetrahedra": [[0, 1, 2, 3]],
                   "name": "x" * 150}).encode()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    port = free_port()
    with serve_process(tmp_path_factory.mktemp("slow"), port, {"TETMORPH_HEAD_TIMEOUT_S": str(LIMIT_S)}) as (url, _):
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
