"""ASGI middleware of the service.

* :class:`ErrorShield` -- an exception that escapes a route becomes the 500
  envelope *without* being re-raised, so the server keeps the keep-alive
  connection open for the client's next request;
* :class:`BodyLimit` -- request bodies over the upload limit answer 413.
"""

from __future__ import annotations

import json
import logging

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .errors import envelope, error_body

__all__ = ["ErrorShield", "BodyLimit"]

log = logging.getLogger("tetmorph.service")


async def send_json(send: Send, status: int, doc: dict[str, object],
                    headers: list[tuple[bytes, bytes]] | None = None) -> None:
    """Send a complete JSON response."""
    body = json.dumps(doc).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()), *(headers or [])]})
    await send({"type": "http.response.body", "body": body})


class ErrorShield:
    """Answer any exception that escapes the app with the 500 envelope, and swallow it."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Handle one ASGI connection."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def tracking_send(msg: Message) -> None:
            nonlocal started
            if msg["type"] == "http.response.start":
                started = True
            await send(msg)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as e:  # noqa: BLE001 - this is the last line of defence
            status, body = error_body(e)
            if started:  # nothing more can be said on this response
                log.error("error after the response started", exc_info=e)
                return
            await send_json(send, status, body)


class BodyLimit:
    """Answer 413 for request bodies over ``limit`` bytes."""

    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Handle one ASGI connection."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.limit:
            size = int(declared)
            await send_json(send, 413, envelope(413, "payload_too_large", f"request body of {size} bytes "
                                                f"exceeds the limit of {self.limit} bytes",
                                                {"bytes": size, "limit": self.limit}))
            return
        seen = 0

        async def counting_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.limit:
                    raise HTTPException(413, f"request body exceeds the limit of {self.limit} bytes")
            return msg

        await self.app(scope, counting_receive, send)
