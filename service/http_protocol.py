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

Both of uvicorn's HTTP/1.1 parsers are bounded, by one timer logic
(:class:`_Paced`): httptools (the default, a declared dependency of the
service extra) through its parser's callbacks, and h11 (``TETMORPH_HTTP_IMPL=h11``,
or where httptools is missing) through the events h11 hands uvicorn.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

__all__ = ["bounded_protocol", "MIN_BODY_RATE"]

log = logging.getLogger("tetmorph.http")
#: Slowest average pace of a request body, in bytes per second (a 56 kbit/s modem sends 7,000).
MIN_BODY_RATE = 1024.0


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


def _expects_body(headers: Any) -> bool:
    """Whether request headers (name, value byte pairs, any case) announce a body."""
    h = {bytes(k).lower(): bytes(v) for k, v in headers}
    length = h.get(b"content-length", b"0").strip()
    return (length.isdigit() and int(length) > 0) or b"chunked" in h.get(b"transfer-encoding", b"").lower()


def _httptools(head_timeout_s: float) -> Any:
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

    class BoundedHttpTools(_Paced, HttpToolsProtocol):
        """:class:`HttpToolsProtocol` that closes a connection whose request head or body is too slow."""

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._pace_start()

        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._head_begins()  # a keep-alive connection's next request

        def on_headers_complete(self) -> None:
            self._head_done(False)
            super().on_headers_complete()
            self._head_done(_expects_body(self.headers))

        def on_body(self, body: bytes) -> None:
            self._body_in(len(body))
            super().on_body(body)

        def on_message_complete(self) -> None:
            self._stop_body_timer()
            super().on_message_complete()

        def connection_lost(self, exc: Exception | None) -> None:
            self._pace_stop()
            super().connection_lost(exc)

    BoundedHttpTools.head_timeout_s = head_timeout_s
    return BoundedHttpTools


def _h11(head_timeout_s: float) -> Any:
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class BoundedH11(_Paced, H11Protocol):
        """:class:`H11Protocol` that closes a connection whose request head or body is too slow.

        h11 has no callbacks: the events it hands uvicorn (``Request``, ``Data``,
        ``EndOfMessage``) are seen on their way, and bytes that arrive while h11
        waits for a request start that request's head.
        """

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._pace_start()
            next_event = self.conn.next_event

            def seen() -> Any:
                event = next_event()
                if isinstance(event, h11.Request):
                    self._head_done(_expects_body(event.headers))
                elif isinstance(event, h11.Data):
                    self._body_in(len(event.data))
                elif isinstance(event, h11.EndOfMessage):
                    self._stop_body_timer()
                return event

            self.conn.next_event = seen  # type: ignore[method-assign]

        def data_received(self, data: bytes) -> None:
            if data and self.conn.their_state is h11.IDLE:
                self._head_begins()  # a keep-alive connection's next request
            super().data_received(data)

        def connection_lost(self, exc: Exception | None) -> None:
            self._pace_stop()
            super().connection_lost(exc)

    BoundedH11.head_timeout_s = head_timeout_s
    return BoundedH11


def bounded_protocol(head_timeout_s: float, impl: str = "auto") -> Any:
    """The HTTP protocol class for ``uvicorn.run(http=...)``.

    Parameters
    ----------
    head_timeout_s : float
    impl : {"auto", "httptools", "h11"}
        ``auto``: httptools when installed, else h11 (both bounded).
    """
    if impl in ("auto", "httptools"):
        try:
            return _httptools(head_timeout_s)
        except ImportError:
            if impl == "httptools":
                raise
    return _h11(head_timeout_s)
