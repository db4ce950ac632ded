"""uvicorn's HTTP protocol with time limits on each request head and on the pace of its body.

uvicorn times out idle keep-alive connections, but not a client that opens a
connection and sends its request line and headers a byte at a time: such a
connection holds a slot for as long as the client cares to drip. Here every
request head (from its first byte, or from the connection for the first
request) must be complete within ``head_timeout_s``, else the connection is
closed.

A body may take long (a large upload over a slow link is a legitimate request;
its size is bounded by :class:`~service.middleware.BodyLimit`), but it must keep
coming: the connection is closed when no byte of it arrives for ``head_timeout_s``,
or when, ``head_timeout_s`` after the head, it has come slower than
:data:`MIN_BODY_RATE` on average. Time the server itself holds the body back
(reading paused while the app has not taken what came, or a ``100-continue``
not yet sent) does not count.

Every request head is also bounded in size (:class:`_Limited`): a request line
and headers over ``max_header_bytes``, or more than ``max_headers`` header lines,
answer 431 ``headers_too_large`` as soon as the parser has seen that much, before
the rest of the head is buffered; an HTTP/1.1 request without ``Host``, or any
request with two, answers 400 ``invalid_host`` (RFC 9112, section 3.2). Such an
answer closes the connection: the server sends it, stops writing, and drops what
the client still sends for at most :data:`LINGER_S` (so that the client reads the
answer instead of a reset), then closes.

Both of uvicorn's HTTP/1.1 parsers are bounded, by one timer logic
(:class:`_Paced`) and one set of head limits (:class:`_Limited`): httptools (the
default, a declared dependency of the service extra) through its parser's
callbacks, and h11 (``TETMORPH_HTTP_IMPL=h11``, or where httptools is missing)
through the events h11 hands uvicorn and h11's own bound on an incomplete head.
"""

from __future__ import annotations

import asyncio
import http
import json
import logging
from typing import Any

from .errors import ServiceError, error_body

__all__ = ["bounded_protocol", "MIN_BODY_RATE", "LINGER_S"]

log = logging.getLogger("tetmorph.http")
#: Slowest average pace of a request body, in bytes per second (a 56 kbit/s modem sends 7,000).
MIN_BODY_RATE = 1024.0
#: Longest a connection stays open, its input dropped, after a refused request head has been answered.
LINGER_S = 2.0


class _Paced:
    """The head and body timers of a connection; the protocol classes below call them from their parser."""

    loop: asyncio.AbstractEventLoop
    transport: asyncio.Transport
    client: Any
    flow: Any
    head_timeout_s: float = 10.0

    @property
    def _step_s(self) -> float:
        return min(1.0, self.head_timeout_s / 4)  # how often a body's pace is checked

    def _pace_start(self) -> None:
        self._head_timer: asyncio.TimerHandle | None = None
        self._body_timer: asyncio.TimerHandle | None = None
        self._body_bytes = 0
        self._body_waited = 0.0  # seconds of the body counted so far (the server's pauses left out)
        self._body_idle = 0.0  # counted seconds since the body's last byte
        self._head_begins()

    def _head_begins(self) -> None:
        """A request head starts (the connection, or a keep-alive connection's next request)."""
        self._stop_body_timer()
        if self._head_timer is None:
            self._head_timer = self.loop.call_later(self.head_timeout_s, self._head_too_slow)

    def _head_done(self, expects_body: bool) -> None:
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None
        if expects_body:
            self._body_bytes, self._body_waited, self._body_idle = 0, 0.0, 0.0
            self._body_timer = self.loop.call_later(self._step_s, self._check_body)

    def _body_in(self, n: int) -> None:
        self._body_bytes += n
        self._body_idle = 0.0

    def _stop_body_timer(self) -> None:
        if self._body_timer is not None:
            self._body_timer.cancel()
            self._body_timer = None

    def _pace_stop(self) -> None:
        self._head_done(False)
        self._stop_body_timer()

    def _head_too_slow(self) -> None:
        self._head_timer = None
        log.info("closed a connection from %s: no complete request head within %g s", self.client,
                 self.head_timeout_s)
        self.transport.close()

    def _held_back(self) -> bool:
        """True while the server, not the client, holds the body back."""
        cycle = getattr(self, "cycle", None)
        return bool(self.flow.read_paused or (cycle is not None and cycle.waiting_for_100_continue))

    def _check_body(self) -> None:
        self._body_timer = None
        step = self._step_s
        if not self._held_back():
            self._body_waited += step
            self._body_idle += step
            slow = (self._body_waited >= self.head_timeout_s
                    and self._body_bytes < MIN_BODY_RATE * self._body_waited)
            if self._body_idle >= self.head_timeout_s or slow:
                log.info("closed a connection from %s: %d body bytes in %.1f s (no byte for %.1f s)",
                         self.client, self._body_bytes, self._body_waited, self._body_idle)
                self.transport.close()
                return
        self._body_timer = self.loop.call_later(step, self._check_body)


class _Refused(Exception):
    """Raised from a parser callback to stop parsing a refused head; the answer is in ``_refusal``."""


class _Limited:
    """The size limits and the ``Host`` rule of request heads, and the answer that refuses one.

    The protocol classes below count what their parser reports (:meth:`_count_head`,
    :meth:`_check_host`); a refusal is kept in ``_refusal``, and uvicorn's answer to a
    parser error (``send_400_response``) sends it instead (:meth:`_send_refusal`).
    """

    loop: asyncio.AbstractEventLoop
    transport: asyncio.Transport
    client: Any
    server_state: Any
    max_header_bytes: int = 64 * 1024
    max_headers: int = 100

    def _limits_start(self) -> None:
        self._refusal: tuple[int, dict[str, Any]] | None = None
        self._discarding = False  # answered and refused: what still comes is dropped
        self._linger: asyncio.TimerHandle | None = None
        self._head_begun()

    def _head_begun(self) -> None:
        self._head_bytes = 0
        self._head_lines = 0

    def _too_large(self, what: str) -> _Refused:
        e = ServiceError("headers_too_large", f"the request head has {what}; the service reads request heads of "
                         f"at most {self.max_header_bytes} bytes (TETMORPH_MAX_HEADER_KB) and "
                         f"{self.max_headers} header lines (TETMORPH_MAX_HEADERS)",
                         limit_bytes=self.max_header_bytes, limit_headers=self.max_headers)
        self._refusal = error_body(e)
        return _Refused(e.message)

    def _count_head(self, n: int, lines: int = 0) -> None:
        """Count ``n`` bytes and ``lines`` header lines of the head being read; raise :class:`_Refused` above."""
        self._head_bytes += n
        self._head_lines += lines
        if self._head_lines > self.max_headers:
            raise self._too_large(f"more than {self.max_headers} header lines")
        if self._head_bytes > self.max_header_bytes:
            raise self._too_large(f"more than {self.max_header_bytes} bytes")

    def _check_host(self, headers: Any, http_version: str) -> None:
        """Raise :class:`_Refused` for an HTTP/1.1 request without ``Host``, or any request with several."""
        hosts = sum(1 for name, _ in headers if bytes(name).lower() == b"host")
        if hosts == 1 or (hosts == 0 and http_version != "1.1"):
            return
        raise self._host_refused(hosts)

    def _host_refused(self, hosts: int) -> _Refused:
        what = "no Host header" if hosts == 0 else "several Host headers"
        e = ServiceError("invalid_host", f"the request has {what}: an HTTP/1.1 request carries exactly one, an "
                         "HTTP/1.0 request at most one (RFC 9112, section 3.2)")
        self._refusal = error_body(e)
        return _Refused(e.message)

    def _send_refusal(self) -> None:
        """Send the refusal, stop writing, and close once the client has read it (or after :data:`LINGER_S`)."""
        assert self._refusal is not None
        status, doc = self._refusal
        body = json.dumps(doc).encode()
        log.info("refused a request head from %s: %d %s", self.client, status, doc["error"]["code"])
        lines = [f"HTTP/1.1 {status} {http.HTTPStatus(status).phrase}".encode()]
        lines += [bytes(name) + b": " + bytes(value) for name, value in self.server_state.default_headers]
        lines += [b"content-type: application/json", b"content-length: %d" % len(body), b"connection: close"]
        self._discarding = True
        stop = getattr(self, "_pace_stop", None)
        if stop is not None:
            stop()
        if self.transport.is_closing():
            return
        self.transport.write(b"\r\n".join(lines) + b"\r\n\r\n" + body)
        if self.transport.can_write_eof():
            self.transport.write_eof()  # the client reads the answer, then the end; its own close ends this
            self._linger = self.loop.call_later(LINGER_S, self.transport.close)
        else:
            self.transport.close()

    def _limits_stop(self) -> None:
        if self._linger is not None:
            self._linger.cancel()
            self._linger = None


def _expects_body(headers: Any) -> bool:
    """Whether request headers (name, value byte pairs, any case) announce a body."""
    h = {bytes(k).lower(): bytes(v) for k, v in headers}
    length = h.get(b"content-length", b"0").strip()
    return (length.isdigit() and int(length) > 0) or b"chunked" in h.get(b"transfer-encoding", b"").lower()


def _httptools(head_timeout_s: float, max_header_bytes: int, max_headers: int) -> Any:
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

    class BoundedHttpTools(_Paced, _Limited, HttpToolsProtocol):
        """:class:`HttpToolsProtocol` bounding request heads and bodies in time and heads in size.

        A connection whose request head or body is too slow is closed; a request head
        that is too large, or lacks its ``Host``, is refused. The parser reports the
        request line in pieces (``on_url``) and each header once it is complete
        (``on_header``); a single header line that never ends is buffered by the
        parser, so the bytes received while a head is incomplete are counted too
        (``data_received``).
        """

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._pace_start()
            self._limits_start()
            self._in_head = True
            self._head_received = 0  # bytes received since the head began, while it is incomplete

        def data_received(self, data: bytes) -> None:
            if self._discarding:
                return
            if self._in_head:
                self._head_received += len(data)
            super().data_received(data)
            if (self._in_head and not self._discarding and not self.transport.is_closing()
                    and self._head_received > self.max_header_bytes):
                self._too_large(f"more than {self.max_header_bytes} bytes")
                self._send_refusal()

        def send_400_response(self, msg: str) -> None:
            if self._refusal is not None:
                self._send_refusal()
            else:
                super().send_400_response(msg)

        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._head_begins()  # a keep-alive connection's next request
            self._head_begun()
            self._in_head = True

        def on_url(self, url: bytes) -> None:
            self._count_head(len(url))
            super().on_url(url)

        def on_header(self, name: bytes, value: bytes) -> None:
            self._count_head(len(name) + len(value) + 4, 1)
            super().on_header(name, value)

        def on_headers_complete(self) -> None:
            self._check_host(self.headers, self.parser.get_http_version())
            self._in_head, self._head_received = False, 0
            self._head_done(False)
            super().on_headers_complete()
            self._head_done(_expects_body(self.headers))

        def on_body(self, body: bytes) -> None:
            self._body_in(len(body))
            super().on_body(body)

        def on_message_complete(self) -> None:
            self._stop_body_timer()
            self._in_head, self._head_received = True, 0
            super().on_message_complete()

        def connection_lost(self, exc: Exception | None) -> None:
            self._pace_stop()
            self._limits_stop()
            super().connection_lost(exc)

    BoundedHttpTools.head_timeout_s = head_timeout_s
    BoundedHttpTools.max_header_bytes = max_header_bytes
    BoundedHttpTools.max_headers = max_headers
    return BoundedHttpTools


def _h11(head_timeout_s: float, max_header_bytes: int, max_headers: int) -> Any:
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class BoundedH11(_Paced, _Limited, H11Protocol):
        """:class:`H11Protocol` bounding request heads and bodies in time and heads in size.

        A connection whose request head or body is too slow is closed; a request head
        that is too large, or lacks its ``Host``, is refused. h11 has no callbacks: the
        events it hands uvicorn (``Request``, ``Data``, ``EndOfMessage``) are seen on
        their way, and bytes that arrive while h11 waits for a request start that
        request's head. h11 itself buffers at most ``max_header_bytes`` of an
        incomplete head (its ``max_incomplete_event_size``; it then raises with the
        hint 431) and refuses a missing or repeated ``Host``; a complete head that came
        at once is measured here.
        """

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.conn = h11.Connection(h11.SERVER, max_incomplete_event_size=self.max_header_bytes)

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._pace_start()
            self._limits_start()
            next_event = self.conn.next_event

            def seen() -> Any:
                try:
                    event = next_event()
                except h11.RemoteProtocolError as e:  # uvicorn answers it with send_400_response
                    if e.error_status_hint == 431:
                        self._too_large(f"more than {self.max_header_bytes} bytes")
                    elif "Host" in str(e):  # "Missing mandatory Host: header", "Found multiple Host: headers"
                        self._host_refused(0 if "Missing" in str(e) else 2)
                    raise
                if isinstance(event, h11.Request):
                    try:
                        self._head_begun()
                        self._count_head(len(event.method) + len(event.target) + 12)
                        for name, value in event.headers:
                            self._count_head(len(name) + len(value) + 4, 1)
                    except _Refused as e:
                        raise h11.RemoteProtocolError(str(e), error_status_hint=431) from None
                    self._head_done(_expects_body(event.headers))
                elif isinstance(event, h11.Data):
                    self._body_in(len(event.data))
                elif isinstance(event, h11.EndOfMessage):
                    self._stop_body_timer()
                return event

            self.conn.next_event = seen  # type: ignore[method-assign]

        def data_received(self, data: bytes) -> None:
            if self._discarding:
                return
            if data and self.conn.their_state is h11.IDLE:
                self._head_begins()  # a keep-alive connection's next request
            super().data_received(data)

        def send_400_response(self, msg: str) -> None:
            if self._refusal is not None:
                self._send_refusal()
            else:
                super().send_400_response(msg)

        def connection_lost(self, exc: Exception | None) -> None:
            self._pace_stop()
            self._limits_stop()
            super().connection_lost(exc)

    BoundedH11.head_timeout_s = head_timeout_s
    BoundedH11.max_header_bytes = max_header_bytes
    BoundedH11.max_headers = max_headers
    return BoundedH11


def bounded_protocol(head_timeout_s: float, impl: str = "auto", max_header_bytes: int = 64 * 1024,
                     max_headers: int = 100) -> Any:
    """The HTTP protocol class for ``uvicorn.run(http=...)``.

    Parameters
    ----------
    head_timeout_s : float
    impl : {"auto", "httptools", "h11"}
        ``auto``: httptools when installed, else h11 (both bounded).
    max_header_bytes, max_headers : int
        The largest request head (request line and headers) and the most header lines (431 above).
    """
    if impl in ("auto", "httptools"):
        try:
            return _httptools(head_timeout_s, max_header_bytes, max_headers)
        except ImportError:
            if impl == "httptools":
                raise
    return _h11(head_timeout_s, max_header_bytes, max_headers)
