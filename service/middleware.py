r"""ASGI middleware of the service.

* :class:`ErrorShield` -- an exception that escapes a route becomes the 500
  envelope *without* being re-raised, so the server keeps the keep-alive
  connection open for the client's next request;
* :class:`BodyLimit` -- request bodies over the upload limit answer 413;
* :class:`UnicodeGuard` -- a JSON body whose text holds a lone UTF-16 surrogate
  (``"\ud800"``: valid JSON, not valid Unicode) answers 422 before a route can
  store it; stored, it could never be answered again (a UTF-8 response cannot
  hold it).
"""

from __future__ import annotations

import json
import logging

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .errors import envelope, error_body, retry_after

__all__ = ["ErrorShield", "BodyLimit", "UnicodeGuard", "lone_surrogate", "may_hold_bad_text"]

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
            wait = retry_after(status, body["error"]["code"])  # a store out of reach, a full data directory
            retry = [(b"retry-after", str(wait).encode())] if wait is not None else None
            await send_json(send, status, body, retry)


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


def may_hold_bad_text(raw: bytes | str) -> bool:
    r"""Whether JSON text ``raw`` can parse to a string :func:`lone_surrogate` refuses.

    UTF-8 cannot encode a surrogate and a JSON string cannot hold a raw NUL, so
    both come only as ``\u`` escapes: text without ``\ud`` or ``\u0000`` (any
    case) needs no walk.
    """
    low = raw.lower().encode() if isinstance(raw, str) else raw.lower()
    return b"\\ud" in low or b"\\u0000" in low


def _bad_text(text: str) -> bool:
    """Whether ``text`` holds a lone surrogate (no UTF-8 encoding) or NUL."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return "\x00" in text


def lone_surrogate(doc: object, path: str = "body") -> str | None:
    r"""Where ``doc`` (parsed JSON) holds a string or key that is not valid Unicode or holds NUL, else None.

    NUL (``"\u0000"``) is valid JSON and Unicode, but PostgreSQL's jsonb cannot
    store it, so the two session stores would disagree on it.

    Examples
    --------
    >>> lone_surrogate({"a": ["ok", "x\ud800"]}), lone_surrogate({"\U0001f600": 1})
    ('body.a[1]', None)
    """
    stack: list[tuple[object, str]] = [(doc, path)]
    while stack:
        x, at = stack.pop()
        if isinstance(x, str):
            if _bad_text(x):
                return at
        elif isinstance(x, dict):
            for k, v in x.items():
                if _bad_text(str(k)):
                    return f"{at} (a key)"
                stack.append((v, f"{at}.{k}"))
        elif isinstance(x, list):
            stack.extend((v, f"{at}[{i}]") for i, v in enumerate(x))
    return None


class UnicodeGuard:
    r"""Answer 422 for a JSON request body holding a lone surrogate escape (see the module docstring).

    Only bodies :func:`may_hold_bad_text` marks are parsed here: the others
    cannot hold one, and pass through untouched.
    """

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Handle one ASGI connection."""
        ctype = dict(scope.get("headers") or []).get(b"content-type", b"")
        if scope["type"] != "http" or b"json" not in ctype:
            await self.app(scope, receive, send)
            return
        messages: list[Message] = []
        body = b""
        while True:
            try:
                msg = await receive()
            except HTTPException as e:  # BodyLimit: over the upload limit
                await send_json(send, e.status_code, envelope(e.status_code, "payload_too_large", str(e.detail), {}))
                return
            messages.append(msg)
            if msg["type"] != "http.request":
                break
            body += msg.get("body", b"")
            if not msg.get("more_body", False):
                break
        if may_hold_bad_text(body):
            try:
                where = lone_surrogate(json.loads(body))
            except (ValueError, RecursionError):
                where = None  # not JSON: the route's own parser answers
            if where is not None:
                await send_json(send, 422, envelope(422, "invalid_request", f"invalid request: {where} holds "
                                                    "a lone UTF-16 surrogate escape (\\ud800-\\udfff "
                                                    "without its pair) or NUL; text must be valid Unicode "
                                                    "without NUL",
                                                    {"field": where}))
                return
        pending = list(messages)

        async def replay() -> Message:
            if pending:
                return pending.pop(0)
            return await receive()

        await self.app(scope, replay, send)
