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
import logging
import socket
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from fastapi import Depends, FastAPI
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles

from solver.kernels import announced, load_kernels
from solver.linalg import threads

from .api import batch, check, health, history, meshes, sessions, stream, study, tetrahedralize, workspace
from .api.deps import refuse_duplicate_keys, refuse_nul
from .api.handlers import install_handlers
from .api.responses import JSONResponse
from .demo import load_demo
from .docs_assets import install_docs
from .errors import envelope
from .middleware import BodyLimit, ErrorShield, UnicodeGuard
from .models.error import ErrorEnvelope
from .observability import Metrics, RequestContext, editor_csp
from .security import Authenticator, ConnectionSlots, load_secret
from .settings import Settings
from .state.batch import clear_jobs, sweep_dead_servers, sweep_job_files
from .state.jobs import JobRunner
from .state.registry import Registry
from .state.sweeper import Sweeper

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


def _load_kernels() -> None:
    """Load the solver's kernels, saying so on standard error when it takes more than a second."""
    with announced("loading the solver's compiled kernels"):
        load_kernels(complete=True)  # the edits' models too: no session waits for them


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
    reg = Registry(settings)
    auth = Authenticator(settings, load_secret(settings.data_dir))
    moved = sum(reg.store.rename_owner(old, new) for old, new in auth.migrations().items())
    if moved:
        log.info("moved %d records to the salted owner ids of the configured keys", moved)
        reg = Registry(settings)  # reload the records with their new owners
    clear_jobs(settings.data_dir, settings.replica_id)  # jobs live in memory: older files are orphans
    if settings.database_url is None:  # a single server: the job folders of its stopped processes are orphans
        dead = sweep_dead_servers(settings.data_dir, socket.gethostname())
        if dead:
            log.info("removed the job folders of %d stopped servers: %s", len(dead), dead[:10])
    removed = reg.store.remove_orphans()
    if removed:
        log.info("removed %d leftovers of interrupted uploads: %s", len(removed), removed[:10])
    threads.configure(max_threads=settings.solver_threads)  # the solve pool and the solver's threads together
    metrics = Metrics()
    reg.moves.observe_solve = metrics.solve_seconds.observe
    reg.builder.observe_build = metrics.build_seconds.observe
    jobs = JobRunner(settings.tetra_workers, settings.tetra_time_limit_s, task_workers=settings.batch_workers)

    orphan_age_s = jobs.keep_s + 60.0  # older than any live job's file (batch.sweep_job_files)
    old = sweep_job_files(settings.data_dir, orphan_age_s)
    if old:
        log.info("removed %d job files left by stopped processes: %s", len(old), old[:10])

    def sweep(now: float) -> list[str]:
        gone = reg.sessions.sweep(now)
        for sid in gone:  # an expired session's batches end with it, as a deleted one's
            jobs.end_session(sid)
        sweep_job_files(settings.data_dir, orphan_age_s, now)
        return gone

    sweeper = Sweeper(sweep, settings.sweep_interval_s)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if settings.load_kernels:  # once per process: later apps of the same process find them loaded
            await asyncio.to_thread(_load_kernels)
        reg.start()
        app.state.jobs.closed = False
        sweeper.start()
        if settings.demo:
            owner = app.state.auth.owner({"x-api-key": settings.api_keys[0].partition("=")[2] or
                                          settings.api_keys[0]} if settings.api_keys else {})
            await load_demo(reg, owner)
        try:
            yield
        finally:
            await sweeper.stop()
            await app.state.jobs.close()
            reg.close()
            reg.close_store()

    app = FastAPI(title="tetmorph", version=_version(), description=DESCRIPTION, lifespan=lifespan,
                  default_response_class=JSONResponse, docs_url=None, redoc_url=None,
                  responses={400: {"model": ErrorEnvelope, "description": "the body cannot be parsed "
                                   "(bad_request): not JSON, or a broken multipart form"},
                             422: {"model": ErrorEnvelope, "description": "invalid request: the error "
                                   "names the field (code invalid_request)"},
                             500: {"model": ErrorEnvelope, "description": "a fault of the server "
                                   "(internal_error); the request is not at fault"}})
    app.state.settings = settings
    app.state.registry = reg
    app.state.auth = auth
    app.state.limiter = reg.store.rate_limiter(settings.rate_limit_per_s, settings.rate_burst)
    app.state.connections = ConnectionSlots(settings.max_connections_per_key)
    app.state.jobs = jobs
    app.state.metrics = metrics
    app.state.sweeper = sweeper
    install_handlers(app)
    app.add_middleware(UnicodeGuard)
    app.add_middleware(BodyLimit, limit=settings.max_upload_bytes)
    app.add_middleware(ErrorShield)
    app.add_middleware(RequestContext, metrics=metrics, replica=settings.replica_id)
    for mod in (meshes, tetrahedralize, sessions, history, workspace, check, batch, study):
        app.include_router(mod.router, prefix="/v1",
                           dependencies=[Depends(refuse_nul), Depends(refuse_duplicate_keys)])
    app.include_router(stream.router, prefix="/v1")  # its frames are checked as they come (parse_frame)
    app.include_router(health.router)
    install_docs(app)  # Swagger UI with its files from the service, not a CDN
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
        return FileResponse(index, media_type="text/html",
                            headers={"Content-Security-Policy": editor_csp(index.read_text())})

    app.mount("/editor", _EditorFiles(directory=EDITOR_DIR, check_dir=False), name="editor")


class _EditorFiles(StaticFiles):
    """The editor's files; 404 naming ``make web`` while it is not built (StaticFiles would raise: a 500)."""

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        """Serve a file of the build, or say that there is no build."""
        if scope["type"] == "http" and not EDITOR_DIR.is_dir():
            body = envelope(404, "not_found", "the browser editor is not built: run `make web` (or `make run`)")
            await JSONResponse(body, status_code=404)(scope, receive, send)
            return
        await super().__call__(scope, receive, send)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tetmorph")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"
