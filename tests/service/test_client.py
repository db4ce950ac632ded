"""service.client.Client: every failure is a TetmorphError; idempotent calls are retried."""

from __future__ import annotations

import socket
import threading

import pytest

from service.client import Client, TetmorphError
from service.process import free_port


def test_no_server_is_a_connection_failure():
    with Client(f"http://127.0.0.1:{free_port()}", retries=1, backoff_s=0.01) as c:
        with pytest.raises(TetmorphError) as e:
            c.mesh("m_x")
    assert e.value.status == 0 and e.value.code == "connection_failed"


def _one_shot_server(responses: list[bytes]) -> tuple[int, list[int], threading.Thread]:
    """A loopback server answering each connection with the next canned response (then closing)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen()
    port = srv.getsockname()[1]
    served: list[int] = []

    def loop() -> None:
        for body in responses:
            conn, _ = srv.accept()
            conn.recv(65536)
            served.append(1)
            if body:
                conn.sendall(body)
            conn.close()
        srv.close()

    t = threading.Thread(target=loop, daemon=True)
    t.start()
    return port, served, t


def test_dropped_connections_are_retried_for_idempotent_calls_and_foreign_answers_are_typed():
    ok = (b'HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ncontent-length: 13\r\n'
          b'connection: close\r\n\r\n{"id": "m_x"}')
    port, served, t = _one_shot_server([b"", ok])  # the first connection is dropped without an answer
    with Client(f"http://127.0.0.1:{port}", retries=2, backoff_s=0.01) as c:
        assert c.mesh("m_x") == {"id": "m_x"}
    t.join(5)
    assert len(served) == 2
    page = (b"HTTP/1.1 502 Bad Gateway\r\ncontent-type: text/html\r\ncontent-length: 11\r\n"
            b"connection: close\r\n\r\n<h1>bad</h1>"[:-1])
    port, served, t = _one_shot_server([page])
    with Client(f"http://127.0.0.1:{port}", retries=0) as c:
        with pytest.raises(TetmorphError) as e:
            c.mesh("m_x")
    assert e.value.status == 502 and e.value.code == "http_error"
    port, served, t = _one_shot_server([b""])  # a POST is not retried: it may have been applied
    with Client(f"http://127.0.0.1:{port}", retries=3, backoff_s=0.01) as c:
        with pytest.raises(TetmorphError) as e:
            c.deform("s_x", {"handles": {}})
    t.join(5)
    assert e.value.code == "connection_failed" and len(served) == 1
