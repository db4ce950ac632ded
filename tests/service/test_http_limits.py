"""A real server bounds request heads and insists on ``Host``, under both of uvicorn's HTTP/1.1 parsers.

A head over ``TETMORPH_MAX_HEADER_KB`` (64 KiB) or with more than ``TETMORPH_MAX_HEADERS`` (100)
header lines answers 431 while it is being read, before the rest is buffered; an HTTP/1.1
request without ``Host`` (or with two) answers 400 (RFC 9112, section 3.2). Each case runs on
httptools (the default) and on h11 (``TETMORPH_HTTP_IMPL=h11``), against ``tetmorph serve`` on a
loopback port, with raw sockets.
"""

from __future__ import annotations

import json
import socket
import threading
import time

import psutil
import pytest

from service.process import free_port, serve_process

#: The defaults of the settings (service/settings.py).
MAX_HEAD = 64 * 1024
MAX_HEADERS = 100


@pytest.fixture(scope="module", params=["httptools", "h11"])
def server(tmp_path_factory, request):
    """(port, server process) of ``tetmorph serve`` on the parser of the parameter, with the default limits."""
    port = free_port()
    env = {"TETMORPH_HTTP_IMPL": request.param, "TETMORPH_LOAD_KERNELS": "0"}
    with serve_process(tmp_path_factory.mktemp("limits"), port, env) as (_, proc):
        yield port, proc


def _answer(sock: socket.socket, deadline: float) -> bytes:
    """What the server sends until it closes, or until one complete answer came (at most until ``deadline``)."""
    got = b""
    while time.monotonic() < deadline:
        sock.settimeout(max(0.05, deadline - time.monotonic()))
        try:
            part = sock.recv(65536)
        except (TimeoutError, OSError):
            break
        if not part:
            break
        got += part
        head, sep, body = got.partition(b"\r\n\r\n")
        if sep:
            length = [line.split(b":", 1)[1].strip() for line in head.split(b"\r\n")[1:]
                      if line.lower().startswith(b"content-length:")]
            if length and len(body) >= int(length[0]):
                break
    return got


def exchange(port: int, request: bytes, timeout_s: float = 15.0) -> tuple[int, dict]:
    """Send ``request`` on a fresh connection; (status, JSON body or {}) of the answer, (0, {}) when none came."""
    deadline = time.monotonic() + timeout_s
    with socket.create_connection(("127.0.0.1", port), timeout=timeout_s) as sock:
        try:
            sock.sendall(request)
        except OSError:
            pass  # the server stopped reading once it had answered: read what it said
        got = _answer(sock, deadline)
    if not got.startswith(b"HTTP/1."):
        return 0, {}
    head, _, body = got.partition(b"\r\n\r\n")
    try:
        doc = json.loads(body) if body else {}
    except ValueError:
        doc = {}
    return int(head.split(b" ", 2)[1]), doc


def _get(*headers: bytes, version: bytes = b"HTTP/1.1", host: bool = True) -> bytes:
    lines = [b"GET /health " + version] + ([b"Host: 127.0.0.1"] if host else []) + list(headers)
    return b"\r\n".join(lines) + b"\r\n\r\n"


def test_a_normal_request_is_answered(server):
    port, _ = server
    assert exchange(port, _get(b"User-Agent: test", b"Accept: */*"))[0] == 200
    many = [b"X-H%d: v" % k for k in range(MAX_HEADERS - 1)]  # with Host: exactly the limit
    assert exchange(port, _get(*many))[0] == 200
    big = b"X-Big: " + b"a" * (MAX_HEAD - 1024)  # a large head under the limit
    assert exchange(port, _get(big))[0] == 200


def test_a_header_block_over_the_byte_limit_answers_431(server):
    port, _ = server
    status, doc = exchange(port, _get(b"X-Big: " + b"a" * 1_000_000))
    assert status == 431, (status, doc)
    assert doc["error"]["code"] == "headers_too_large" and doc["error"]["details"]["limit_bytes"] == MAX_HEAD
    assert exchange(port, _get())[0] == 200  # the server goes on serving


def test_too_many_header_lines_answer_431(server):
    port, _ = server
    status, doc = exchange(port, _get(*[b"X-H%d: v" % k for k in range(1000)]))
    assert status == 431, (status, doc)
    assert doc["error"]["code"] == "headers_too_large" and doc["error"]["details"]["limit_headers"] == MAX_HEADERS
    status, _ = exchange(port, _get(*[b"X-H%d: v" % k for k in range(MAX_HEADERS)]))  # one over, with Host
    assert status == 431


def test_huge_header_blocks_in_parallel_leave_the_server_small(server):
    """Four clients each sending a 32 MB header block: each answered 431, the server's memory barely moves."""
    port, proc = server
    server_proc = psutil.Process(proc.pid)
    before = server_proc.memory_info().rss
    peak = [before]
    done = threading.Event()

    def sample() -> None:
        while not done.is_set():
            try:
                peak[0] = max(peak[0], server_proc.memory_info().rss)
            except psutil.Error:
                return
            time.sleep(0.01)

    statuses: list[int] = []

    def client() -> None:
        statuses.append(exchange(port, _get(b"X-Big: " + b"a" * (32 << 20)), timeout_s=30)[0])

    sampler = threading.Thread(target=sample)
    sampler.start()
    clients = [threading.Thread(target=client) for _ in range(4)]
    try:
        for t in clients:
            t.start()
        for t in clients:
            t.join(timeout=60)
    finally:
        done.set()
        sampler.join(timeout=5)
    assert statuses == [431] * 4, statuses
    grown = (peak[0] - before) / 2**20
    assert grown < 24, f"the server grew by {grown:.0f} MiB while refusing 128 MB of headers"
    assert exchange(port, _get())[0] == 200


def test_an_http11_request_without_host_answers_400(server):
    port, _ = server
    status, doc = exchange(port, _get(host=False))
    assert status == 400 and doc["error"]["code"] == "invalid_host", (status, doc)
    status, doc = exchange(port, _get(b"Host: other.example"))  # two Host lines
    assert status == 400 and doc["error"]["code"] == "invalid_host", (status, doc)
    assert exchange(port, _get(host=False, version=b"HTTP/1.0"))[0] == 200  # HTTP/1.0 needs none
