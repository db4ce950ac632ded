"""``/health`` (liveness), ``/ready`` (readiness), ``/metrics`` (Prometheus) and ``/v1/formats``."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from solver.linalg import threads

from ..formats import capabilities
from ..models.error import error_responses
from ..models.service import FormatInfo, Health, Ready
from ..state.session import SessionStatus
from .deps import OwnerDep, RegistryDep, SettingsDep
from .responses import JSONResponse

router = APIRouter(tags=["service"])


@router.get("/health", summary="Liveness and cache figures (no key needed)", response_model=Health)
def health(request: Request, reg: RegistryDep, settings: SettingsDep) -> dict[str, Any]:
    """Answers as long as the event loop runs."""
    return {"status": "ok", "version": request.app.version, "replica": settings.replica_id,
            "sessions": len(reg.sessions),
            "cached_sessions": reg.cached_sessions, "cache_bytes": reg.cache_bytes,
            "cache_budget_bytes": settings.cache_budget_bytes, "evictions": reg.evictions}


@router.get("/ready", summary="Readiness: store writable, workers alive (no key needed)", response_model=Ready,
            responses={503: {"model": Ready, "description": "not ready; checks says what fails"}})
def ready(request: Request, reg: RegistryDep) -> JSONResponse:
    """200 when the store takes records (data directory, database) and the workers and the sweeper run, else 503."""
    state = request.app.state
    pool = reg.parse.health()
    checks = {"store_writable": reg.store.writable(),
              "workers": not reg.builder.closed and state.jobs.alive,
              "sweeper": state.sweeper.alive,
              "parse_workers": not (pool["stuck"] or pool["saturated"])}
    ok = all(checks.values())
    return JSONResponse({"ready": ok, "checks": checks}, status_code=200 if ok else 503)


@router.get("/metrics", summary="Prometheus metrics (no key needed)",
            responses={200: {"content": {CONTENT_TYPE_LATEST: {}}}})
def metrics(request: Request, reg: RegistryDep) -> Response:
    """Requests by route and status, build and solve durations, queue depths, cache bytes, sessions."""
    m = request.app.state.metrics
    m.cache_bytes.set(reg.cache_bytes)
    counts = {s.value: 0 for s in SessionStatus}
    for s in reg.sessions.values():
        counts[s.status.value] += 1
    for k, v in counts.items():
        m.sessions.labels(k).set(v)
    m.queue.labels("build").set(reg.builder.queued("build"))
    m.queue.labels("solve").set(reg.builder.queued("solve"))
    m.queue.labels("tetrahedralize").set(request.app.state.jobs.queued)
    m.solves_in_flight.set(threads.in_flight())
    m.solve_threads.set(threads.free_threads(threads.in_flight() + 1))
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)


@router.get("/v1/formats", summary="Mesh formats this installation reads and writes",
            response_model=list[FormatInfo], responses=error_responses(401, 429))
def formats(_owner: OwnerDep) -> list[dict[str, Any]]:
    """Every known format, whether it is offered here, and what it keeps (sets, tetra10, mixed)."""
    return list(capabilities())
