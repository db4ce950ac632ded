"""uvicorn's HTTP protocol with a time limit on each request head.

uvicorn times out idle keep-alive connections, but not a client that opens a
connection and sends its request line and headers a byte at a time: such a
connection holds a slot for as long as the client cares to drip. Here every
request head (from its first byte, or from the connection for the first
request) must be complete within ``head_timeout_s``, else the connection is
closed. The body is not bounded here: a large upload over a slow link is a
legitimate request, and the body size is bounded by
:class:`~service.middleware.BodyLimit`.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

__all__ = ["bounded_protocol"]

log = logging.getLogger("tetmorph.http")


def bounded_protocol(head_timeout_s: float) -> Any:
    """The HTTP protocol class for ``uvicorn.run(http=...)``; None when httptools is not installed."""
    try:
        from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol
    except ImportError:  # uvicorn falls back to h11: no head limit there
        return None

    class BoundedHead(HttpToolsProtocol):
        """:class:`HttpToolsProtocol` that closes a connection whose request head is too slow."""

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._head_timer: asyncio.TimerHandle | None = None
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

        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._start_head_timer()  # a keep-alive connection's next request

        def on_headers_complete(self) -> None:
            self._stop_head_timer()
            super().on_headers_complete()

        def connection_lost(self, exc: Exception | None) -> None:
            self._stop_head_timer()
            super().connection_lost(exc)

    return BoundedHead
