"""``/v1/sessions``: create from a mesh and a SPEC, deform by MOVEs, download, reset, delete."""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Body, Header, Query, Response
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from solver.validity.quality import METRICS, element_quality, summarize_quality

from ..binary import MEDIA_TYPE, encode_frame
from ..errors import ServiceError
from ..formats import export_mesh
from ..registry import Registry, Session
from .deps import Owner, Reg, safe_name

router = APIRouter(tags=["sessions"])

Kind = Literal["positions", "displacements"]
Dtype = Literal["float32", "float64"]


class SessionCreate(BaseModel):
    """Create a session: which mesh, and the SPEC (selections, fixed, handles, options)."""

    mesh_id: str = Field(..., description="id from POST /v1/meshes")
    spec: dict[str, Any] = Field(..., description="the SPEC document (README, 'SPEC')")


def _status_code(s: Session) -> int:
    return 201 if s.status == "ready" else 202


@router.post("/sessions", status_code=201, summary="Create a session (assemble and factor)",
             responses={202: {"description": "still building; poll GET /v1/sessions/{id}"}})
async def create_session(body: SessionCreate, owner: str = Owner, reg: Registry = Reg
                         ) -> JSONResponse:
    """Resolve the SPEC on the mesh and factor its systems.

    SPEC errors (unknown names, empty selections, unconstrained parts) answer
    422 here. A build that takes longer than ``build_wait_s`` answers 202;
    poll the session until ``status`` is ``ready``.
    """
    s = await reg.create_session(owner, body.mesh_id, body.spec)
    return JSONResponse(s.doc(), status_code=_status_code(s),
                        headers={"Location": f"/v1/sessions/{s.id}"})


@router.get("/sessions", summary="List your sessions")
def list_sessions(owner: str = Owner, reg: Registry = Reg) -> list[dict[str, Any]]:
    """Every session of the caller's key."""
    return [s.doc() for s in reg.list_sessions(owner)]


@router.get("/sessions/{session_id}", summary="Session status, progress and last report")
def get_session(session_id: str, owner: str = Owner, reg: Registry = Reg) -> dict[str, Any]:
    """Status (``building``, ``ready``, ``evicted``, ``stored``, ``failed``), progress, timings."""
    return reg.session(owner, session_id).doc()


def result_response(V: np.ndarray, V0: np.ndarray, report: dict[str, Any], result: str, kind: str,
                    dtype: str, extra: dict[str, Any] | None = None) -> Response:
    """Encode a deform result as JSON or as a binary frame."""
    X = V if kind == "positions" else V - V0
    if result == "binary":
        return Response(encode_frame(X, {"report": report, **(extra or {})}, dtype, kind),
                        media_type=MEDIA_TYPE)
    body: dict[str, Any] = {"report": report, **(extra or {})}
    if result == "json":
        body["kind"] = kind
        body[kind] = np.asarray(X, dtype=np.float32 if dtype == "float32" else np.float64).tolist()
    return JSONResponse(body)


@router.post("/sessions/{session_id}/deform", summary="Apply a MOVE",
             responses={200: {"content": {"application/json": {}, MEDIA_TYPE: {}}},
                        422: {"description": "bad MOVE, or an inverting move under 'reject' "
                                             "(details.report); the session is unchanged"}})
async def deform(
    session_id: str,
    move: Annotated[dict[str, Any], Body(description="the MOVE document",
                                         examples=[{"handles": {"tip": {"translation": [0, 0, 1]}}}])],
    result: Annotated[Literal["json", "binary", "report", "mesh"] | None, Query(
        description="json (report + array), binary (frame, see README), report only, or a mesh "
                    "file; default json, or binary when Accept is application/octet-stream")] = None,
    kind: Annotated[Kind, Query()] = "positions",
    dtype: Annotated[Dtype, Query()] = "float64",
    format: Annotated[str, Query(description="mesh format for result=mesh")] = "vtu",
    inversion: Annotated[Literal["warn", "reject", "clamp"] | None, Query(
        description="override the SPEC's inversion policy; 'clamp' applies the largest safe "
                    "fraction of an inverting MOVE")] = None,
    quality: Annotated[Literal["basic", "full"], Query(
        description="full: REPORT quality summaries before/after (volume, scaled Jacobian, "
                    "dihedral angles, aspect ratio; histograms) and, with result=mesh, per-element "
                    "metrics as cell data")] = "basic",
    repair: Annotated[bool | None, Query(description="override SPEC.repair: untangle inverted "
                                         "elements by moving free interior vertices")] = None,
    accept: Annotated[str | None, Header()] = None,
    owner: str = Owner, reg: Registry = Reg,
) -> Response:
    """Back-substitute for the MOVE and answer the REPORT and the result."""
    s = reg.session(owner, session_id)
    r = await reg.deform(s, move, inversion, quality, repair)
    mode = result or ("binary" if accept and MEDIA_TYPE in accept else "json")
    if mode == "mesh":
        return await _mesh_response(reg, s, r.V, format, r.report, quality == "full")
    mesh = await reg.session_mesh(s)
    return result_response(r.V, mesh.V, r.report, mode, kind, dtype)


async def _mesh_response(reg: Registry, s: Session, V: np.ndarray, fmt: str,
                         report: dict[str, Any] | None, quality: bool = False) -> Response:
    mesh = await reg.session_mesh(s)
    meta = reg.store.mesh_meta(s.mesh_id) or {}
    stem = safe_name(str(meta.get("name", "mesh")).rsplit(".", 1)[0], "mesh") + "_deformed"
    body, fname, media = await reg.run(export_mesh, mesh, V, fmt, stem, quality)
    headers = {"Content-Disposition": f'attachment; filename="{fname}"'}
    if report is not None:
        small = {k: report[k] for k in ("inverted_elements", "degenerate_elements",
                                        "min_scaled_jacobian", "constraint_residual_max",
                                        "max_displacement") if k in report}
        headers["X-Tetmorph-Report"] = json.dumps(small, separators=(",", ":"))
    return Response(body, media_type=media, headers=headers)


@router.get("/sessions/{session_id}/mesh", summary="Download the current deformed mesh",
            responses={200: {"content": {"application/octet-stream": {}}}})
async def download_current(
    session_id: str,
    format: Annotated[str, Query(description="format name or extension")] = "vtu",
    quality: Annotated[bool, Query(description="per-element quality metrics as cell data")] = False,
    owner: str = Owner, reg: Registry = Reg,
) -> Response:
    """The mesh at the session's last MOVE (rest shape before any), in any format."""
    s = reg.session(owner, session_id)
    V = await reg.positions(s)
    return await _mesh_response(reg, s, V, format, s.report, quality)


@router.get("/sessions/{session_id}/quality", summary="Per-element quality of the current mesh")
async def current_quality(
    session_id: str,
    metrics: Annotated[str | None, Query(description="comma-separated subset of "
                                         f"{list(METRICS)}; default all")] = None,
    owner: str = Owner, reg: Registry = Reg,
) -> dict[str, Any]:
    """Per-element metrics at the last MOVE (one list per metric; tets in file order, then hexahedra,
    wedges and pyramids; NaN where a metric is for tets only) and summaries."""
    s = reg.session(owner, session_id)
    names = list(METRICS) if metrics is None else [m.strip() for m in metrics.split(",") if m.strip()]
    bad = sorted(set(names) - set(METRICS))
    if bad or not names:
        raise ServiceError(422, f"unknown metrics {bad}; choose from {list(METRICS)}",
                           code="unknown_metric", unknown=bad)
    V = await reg.positions(s)
    mesh = await reg.session_mesh(s)
    q = await reg.run(element_quality, V, mesh.T, mesh.cells)
    return {"elements": mesh.elements, "summary": summarize_quality({k: q[k] for k in names}),
            "per_element": {k: _json_floats(q[k]) for k in names}}


def _json_floats(x: np.ndarray) -> list[float | None]:
    """A float array as a JSON list, NaN (tet-only metrics on other elements) as null."""
    out = x.astype(object)
    out[np.isnan(x)] = None
    return out.tolist()


@router.get("/sessions/{session_id}/positions", summary="Current positions as JSON or binary",
            responses={200: {"content": {"application/json": {}, MEDIA_TYPE: {}}}})
async def current_positions(
    session_id: str,
    result: Annotated[Literal["json", "binary"], Query()] = "json",
    kind: Annotated[Kind, Query()] = "positions",
    dtype: Annotated[Dtype, Query()] = "float64",
    owner: str = Owner, reg: Registry = Reg,
) -> Response:
    """The current state, encoded like a deform result."""
    s = reg.session(owner, session_id)
    V = await reg.positions(s)
    mesh = await reg.session_mesh(s)
    return result_response(V, mesh.V, s.report or {}, result, kind, dtype)


@router.post("/sessions/{session_id}/reset", summary="Back to the rest shape")
async def reset(session_id: str, owner: str = Owner, reg: Registry = Reg) -> dict[str, Any]:
    """Forget the last MOVE; the factorization stays."""
    s = reg.session(owner, session_id)
    await reg.reset(s)
    return s.doc()


@router.delete("/sessions/{session_id}", status_code=204, summary="Delete a session")
async def delete_session(session_id: str, owner: str = Owner, reg: Registry = Reg) -> Response:
    """Drop the session and its factorization."""
    s = reg.session(owner, session_id)
    await reg.delete_session(s)
    return Response(status_code=204)
