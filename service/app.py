"""The application factory: ``create_app(settings)`` returns a configured FastAPI app.

Examples
--------
>>> from service.settings import Settings
>>> app = create_app(Settings(data_dir="/tmp/tetmorph-doctest"))
>>> sorted(r.path for r in app.routes if r.path.startswith("/v1/sessions"))[:2]
['/v1/sessions', '/v1/sessions/{session_id}']
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .api import meshes, sessions, stream, tetrahedralize
from .demo import load_demo
from .errors import envelope, install_handlers
from .registry import Registry
from .security import Authenticator, RateLimiter
from .settings import Settings

__all__ = ["create_app"]

log = logging.getLogger("tetmorph.service")

DESCRIPTION = """\
Volumetric deformation of tetrahedral FE meshes with exact hard constraints.

Upload a mesh, create a session from it and a SPEC (fixed selections and
handles), then POST MOVEs: each update is a back-substitution against the
session's cached factorization and returns the deformed positions (JSON, a
compact binary frame, or any mesh format) with a REPORT that counts inverted
elements. Every error has the body
`{"error": {"status", "code", "type", "message", "details"}}`.
"""


class BodyLimit:
    """ASGI middleware: answer 413 for request bodies over ``limit`` bytes."""

    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.limit:
            await _send_413(send, int(declared), self.limit)
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


async def _send_413(send: Send, size: int, limit: int) -> None:
    body = json.dumps(envelope(413, "payload_too_large",
                               f"request body of {size} bytes exceeds the limit of {limit} bytes",
                               {"bytes": size, "limit": limit})).encode()
    await send({"type": "http.response.start", "status": 413,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()),
                            (b"connection", b"close")]})
    await send({"type": "http.response.body", "body": body})


def create_app(settings: Settings | None = None, **overrides: Any) -> FastAPI:
    """Build the tetmorph service.

    Parameters
    ----------
    settings : Settings, optional
        Defaults to the ``TETMORPH_*`` environment.
    **overrides
        Individual settings (``data_dir=...``) applied on top.

    Returns
    -------
    FastAPI
    """
    if settings is None:
        settings = Settings(**overrides)
    elif overrides:
        settings = Settings(**{**settings.model_dump(), **overrides})

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        reg: Registry = app.state.registry
        if reg._closed:
            reg.start()

        async def sweeper() -> None:
            while True:
                await asyncio.sleep(settings.sweep_interval_s)
                reg.sweep()

        task = asyncio.create_task(sweeper())
        if settings.demo:
            owner = settings.api_keys[0] if settings.api_keys else None
            await load_demo(reg, app.state.auth.owner({"x-api-key": owner} if owner else {}, {}))
        try:
            yield
        finally:
            task.cancel()
            reg.close()

    app = FastAPI(title="tetmorph", version=_version(), description=DESCRIPTION, lifespan=lifespan)
    app.state.settings = settings
    app.state.registry = Registry(settings)
    app.state.auth = Authenticator(settings)
    app.state.limiter = RateLimiter(settings.rate_limit_per_s, settings.rate_burst)
    install_handlers(app)
    app.add_middleware(BodyLimit, limit=settings.max_upload_bytes)
    for mod in (meshes, tetrahedralize, sessions, stream):
        app.include_router(mod.router, prefix="/v1")

    @app.get("/health", tags=["service"], summary="Liveness and cache figures (no key needed)")
    def health() -> dict[str, Any]:
        reg: Registry = app.state.registry
        return {"status": "ok", "version": app.version, "sessions": len(reg.sessions),
                "cached_sessions": reg.cached_sessions, "cache_bytes": reg.cache_bytes,
                "cache_budget_bytes": settings.cache_budget_bytes, "evictions": reg.evictions}

    _mount_editor(app)
    return app


#: Where ``web/build.mjs`` puts the browser editor (``make web``).
EDITOR_DIR = Path(__file__).parent / "static" / "editor"


def _mount_editor(app: FastAPI) -> None:
    """Serve the browser editor at ``/`` and its files under ``/editor/``."""

    @app.get("/", include_in_schema=False)
    def editor() -> Response:
        index = EDITOR_DIR / "index.html"
        if not index.is_file():
            return HTMLResponse(
                "<h1>tetmorph</h1><p>The browser editor is not built. Run <code>make web</code> "
                "(or <code>make run</code>), then reload. The REST API is at <a href=\"/docs\">/docs</a>.</p>",
                status_code=503)
        return FileResponse(index, media_type="text/html")

    app.mount("/editor", StaticFiles(directory=EDITOR_DIR, check_dir=False), name="editor")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tetmorph")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"
