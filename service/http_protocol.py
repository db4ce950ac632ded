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
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

__all__ = ["bounded_protocol", "MIN_BODY_RATE"]

log = logging.getLogger("tetmorph.http")
#: Slowest average pace of a request body, in bytes per second (a 56 kbit/s modem sends 7,000).
MIN_BODY_RATE = 1024.0


def bounded_protocol(head_timeout_s: float) -> Any:
    """The HTTP protocol class for ``uvicorn.run(http=...)``; None when httptools is not installed."""
    try:
        from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol
    except ImportError:  # uvicorn falls back to h11: no head limit there
        return None

    step_s = min(1.0, head_timeout_s / 4)  # how often a body's pace is checked

    class BoundedHead(HttpToolsProtocol):
        """:class:`HttpToolsProtocol` that closes a connection whose request head or body is too slow."""

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._head_timer: asyncio.TimerHandle | None = None
            self._body_timer: asyncio.TimerHandle | None = None
            self._body_bytes = 0
            self._body_waited = 0.0  # seconds of the body counted so far (the server's pauses left out)
            self._body_idle = 0.0  # counted seconds since the body's last byte
            self._start_head_timer()

        def _start_head_timer(self) -> None:
            if self._head_timer is None:
                self._head_timer = self.loop.call_later(head_timeout_s, self._head_too_slow)

        def _stop_head_timer(self) -> None:
            if self._head_timer is not None:
                self._head_timer.cancel()
                self._head_timer = None

        def _head_too_slow(self) -> None:
            self._head_timer = None
            log.info("closed a connection from %s: no complete request head within %g s", self.client,
                     head_timeout_s)
            self.transport.close()

        def _expects_body(self) -> bool:
            headers = dict(self.headers)
            length = headers.get(b"content-length", b"0").strip()
            return (length.isdigit() and int(length) > 0) or b"chunked" in headers.get(b"transfer-encoding", b"")

        def _stop_body_timer(self) -> None:
            if self._body_timer is not None:
                self._body_timer.cancel()
                self._body_timer = None

        def _held_back(self) -> bool:
            """True while the server, not the client, holds the body back."""
            cycle = getattr(self, "cycle", None)
            return bool(self.flow.read_paused or (cycle is not None and cycle.waiting_for_100_continue))

        def _check_body(self) -> None:
            self._body_timer = None
            if not self._held_back():
                self._body_waited += step_s
                self._body_idle += step_s
                slow = (self._body_waited >= head_timeout_s
                        and self._body_bytes < MIN_BODY_RATE * self._body_waited)
                if self._body_idle >= head_timeout_s or slow:
                    log.info("closed a connection from %s: %d body bytes in %.1f s (no byte for %.1f s)",
                             self.client, self._body_bytes, self._body_waited, self._body_idle)
                    self.transport.close()
                    return
            self._body_timer = self.loop.call_later(step_s, self._check_body)

        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._stop_body_timer()
            self._start_head_timer()  # a keep-alive connection's next request

        def on_headers_complete(self) -> None:
            self._stop_head_timer()
            super().on_headers_complete()
            if self._expects_body():
                self._body_bytes, self._body_waited, self._body_idle = 0, 0.0, 0.0
                self._body_timer = self.loop.call_later(step_s, self._check_body)

        def on_body(self, body: bytes) -> None:
            self._body_bytes += len(body)
            self._body_idle = 0.0
            super().on_body(body)

        def on_message_complete(self) -> None:
            self._stop_body_timer()
            super().on_message_complete()

        def connection_lost(self, exc: Exception | None) -> None:
            self._stop_head_timer()
            self._stop_body_timer()
            super().connection_lost(exc)

    return BoundedHead
