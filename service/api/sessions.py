"""``/v1/sessions``: create from a mesh and a SPEC, deform by MOVEs, keep presets, download, reset, delete."""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Body, Header, Query, Request, Response
from pydantic import BaseModel

from solver.documents.report import Report
from solver.validity.quality import METRICS, element_quality, summarize_quality

from ..binary import MEDIA_TYPE, encode_frame
from ..errors import ServiceError
from ..formats import check_export, export_mesh
from ..models.error import error_responses
from ..models.formats import MESH_FORMAT_VALUES
from ..models.move import Move
from ..models.session import SessionDoc, SessionPatch
from ..models.uploads import SessionCreate
from ..state.kept import refresh_presets, set_presets
from ..state.registry import Registry
from ..state.session import Session, SessionStatus
from .deps import OwnerDep, RegistryDep, SessionDep, safe_name
from .paging import PAGE_HEADERS, CursorQuery, LimitQuery, NameQuery, page
from .responses import JSONResponse

_METRIC = "(" + "|".join(METRICS) + ")"
#: ``metrics=``: metric names separated by commas, blanks around each, at least one name (stated in the
#: schema; the route's check answers 422 ``unknown_metric`` naming the others).
METRICS_PATTERN = rf"^([ \t]*,)*[ \t]*{_METRIC}[ \t]*(,[ \t]*({_METRIC}[ \t]*)?)*$"

router = APIRouter(tags=["sessions"])

Kind = Literal["positions", "displacements"]
Dtype = Literal["float32", "float64"]
_AUTH = (401, 429)
#: The session's version after a MOVE (deform) or of the positions answered.
VERSION_HEADER = "X-Tetmorph-Version"


class DeformJSON(BaseModel):
    """A deform answer with ``result=json``: the REPORT and the (n, 3) positions or displacements."""

    report: Report
    kind: Kind | None = None
    positions: list[list[float]] | None = None
    displacements: list[list[float]] | None = None


def doc_of(reg: Registry, s: Session) -> dict[str, Any]:
    """The session document with its expiry time."""
    return s.doc(reg.settings.session_ttl_s)


@router.post("/sessions", status_code=201, summary="Create a session (assemble and factor)",
             response_model=SessionDoc,
             responses={201: {"description": "ready"},
                        202: {"model": SessionDoc, "description": "still building; poll GET /v1/sessions/{id}"},
                        **error_responses(*_AUTH, 404, 413, 422, 500, s404="unknown mesh (mesh_not_found)",
                                          s422="the SPEC does not fit the mesh: the field, names, ids")})
async def create_session(body: SessionCreate, owner: OwnerDep, reg: RegistryDep) -> JSONResponse:
    """Resolve the SPEC on the mesh and factor its systems.

    SPEC errors (unknown names, empty selections, unconstrained parts) answer
    422 here. A build that takes longer than ``build_wait_s`` answers 202;
    poll the session until ``status`` is ``ready``.
    """
    s = await reg.sessions.create(owner, body.mesh_id, body.spec.dump())
    return JSONResponse(doc_of(reg, s), status_code=201 if s.status is SessionStatus.ready else 202,
                        headers={"Location": f"/v1/sessions/{s.id}"})


@router.get("/sessions", summary="List your sessions", response_model=list[SessionDoc],
            responses={200: {"headers": PAGE_HEADERS}, **error_responses(*_AUTH, 422)})
def list_sessions(owner: OwnerDep, reg: RegistryDep, request: Request, response: Response,
                  limit: LimitQuery = 100, cursor: CursorQuery = None, name: NameQuery = None,
                  mesh_id: Annotated[str | None, Query(max_length=64, description="only sessions of this mesh")]
                  = None) -> list[dict[str, Any]]:
    """The caller's sessions, oldest first; ``name`` filters by a substring of the mesh's name."""
    rows = reg.sessions.owned(owner)
    if mesh_id is not None:
        rows = [s for s in rows if s.mesh_id == mesh_id]
    if name is not None:
        names = {m["id"]: str(m.get("name", "")) for m in reg.catalogue.owned(owner)}
        rows = [s for s in rows if name in names.get(s.mesh_id, "")]
    return [doc_of(reg, s) for s in page(rows, lambda s: (s.created, s.id), limit, cursor, request, response)]


@router.get("/sessions/{session_id}", summary="Session status, progress and last report",
            response_model=SessionDoc, responses=error_responses(*_AUTH, 404, 410))
def get_session(s: SessionDep, reg: RegistryDep) -> dict[str, Any]:
    """Status (``building``, ``ready``, ``evicted``, ``stored``, ``failed``), progress, timings, presets."""
    refresh_presets(reg.sessions, s)
    return doc_of(reg, s)


@router.patch("/sessions/{session_id}", summary="Keep named MOVE presets with the session",
              response_model=SessionDoc, responses=error_responses(
                  *_AUTH, 404, 410, 413, 422,
                  s422="bad presets, naming the field (presets[k].move..., a repeated name, more than 100); "
                       "the stored presets are unchanged"))
async def patch_session(
    s: SessionDep, reg: RegistryDep,
    body: Annotated[SessionPatch, Body(description="``presets`` replaces the session's list")],
) -> dict[str, Any]:
    """Replace the session's presets: named MOVEs, each validated like a deform's MOVE.

    They are kept with the session (across restarts, on every replica) and
    answered in its document; they are not its morph state: the version,
    the last MOVE and the positions do not change, and a MOVE being solved
    meanwhile commits as usual. Apply one with POST .../deform.
    """
    set_presets(reg.sessions, s, body.dump())
    return doc_of(reg, s)


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


_DEFORM_200 = {"model": DeformJSON, "content": {MEDIA_TYPE: {"schema": {"type": "string", "format": "binary"}},
                                                "application/zip": {"schema": {"type": "string", "format": "binary"}}},
               "description": "the REPORT and the result (JSON, the binary frame of the service guide, or a mesh: "
                              "a zip when the format has several files, or the deck includes files)"}


@router.post("/sessions/{session_id}/deform", summary="Apply a MOVE",
             responses={200: _DEFORM_200, **error_responses(
                 *_AUTH, 404, 409, 410, 413, 422, 500,
                 s409="version_conflict: another replica committed a MOVE of this session while this one "
                      "was solved; nothing was committed, retry",
                 s422="bad MOVE (the field), out_of_range, or an inverting move under 'reject' "
                      "(inverted_elements, details.report); the session is unchanged")})
async def deform(
    s: SessionDep, reg: RegistryDep,
    move: Annotated[Move, Body(description="the MOVE document")],
    result: Annotated[Literal["json", "binary", "report", "mesh"] | None, Query(
        description="json (report + array), binary (frame: docs/guide/service.md), report only, or a mesh "
                    "file; default json, or binary when Accept is application/octet-stream")] = None,
    kind: Annotated[Kind, Query()] = "positions",
    dtype: Annotated[Dtype, Query()] = "float64",
    format: Annotated[str, Query(max_length=40, description="mesh format for result=mesh",
                                 json_schema_extra={"enum": MESH_FORMAT_VALUES})] = "vtu",
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
) -> Response:
    """Back-substitute for the MOVE and answer the REPORT and the result."""
    mode = result or ("binary" if accept and MEDIA_TYPE in accept else "json")
    if mode == "mesh":  # the whole request is valid before anything is solved or committed
        await reg.run(check_export, await reg.sessions.mesh(s), format, quality == "full")
    r = await reg.moves.deform(s, move, inversion, quality, repair)
    version = str(s.version)  # read before the next await: the version this MOVE committed
    if mode == "mesh":
        resp = await _mesh_response(reg, s, r.V, format, r.report, quality == "full")
    else:
        mesh = await reg.sessions.mesh(s)
        resp = result_response(r.V, mesh.V, r.report, mode, kind, dtype)
    resp.headers[VERSION_HEADER] = version
    return resp


async def _mesh_response(reg: Registry, s: Session, V: np.ndarray, fmt: str,
                         report: dict[str, Any] | None, quality: bool = False, lossy: bool = False) -> Response:
    mesh = await reg.sessions.mesh(s)
    meta = reg.store.mesh_meta(s.mesh_id) or {}
    stem = safe_name(str(meta.get("name", "mesh")).rsplit(".", 1)[0], "mesh") + "_deformed"
    body, fname, media, dropped = await reg.run(export_mesh, mesh, V, fmt, stem, quality, lossy)
    headers = {"Content-Disposition": f'attachment; filename="{fname}"'}
    if dropped:
        headers["X-Tetmorph-Dropped"] = json.dumps(dropped, separators=(",", ":"))
    if report is not None:
        small = {k: report[k] for k in ("inverted_elements", "degenerate_elements",
                                        "min_scaled_jacobian", "constraint_residual_max",
                                        "max_displacement") if k in report}
        headers["X-Tetmorph-Report"] = json.dumps(small, separators=(",", ":"))
    return Response(body, media_type=media, headers=headers)


@router.get("/sessions/{session_id}/mesh", summary="Download the current deformed mesh",
            responses={200: {"content": {"application/octet-stream": {}, "application/zip": {}},
                             "description": "the file (a zip when the format has several files, or the deck "
                                            "includes files: each under its path relative to the deck)"},
                       **error_responses(*_AUTH, 404, 410, 422)})
async def download_current(
    s: SessionDep, reg: RegistryDep,
    format: Annotated[str, Query(max_length=40, description="format name or extension",
                                 json_schema_extra={"enum": MESH_FORMAT_VALUES})] = "vtu",
    quality: Annotated[bool, Query(description="per-element quality metrics as cell data")] = False,
    lossy: Annotated[bool, Query(description="write what the format can hold; X-Tetmorph-Dropped lists "
                                 "the rest (else 422 lossy_write)")] = False,
) -> Response:
    """The mesh at the session's last MOVE (rest shape before any), in any format."""
    V = await reg.moves.positions(s)
    return await _mesh_response(reg, s, V, format, s.report, quality, lossy)


@router.get("/sessions/{session_id}/quality", summary="Per-element quality of the current mesh",
            responses=error_responses(*_AUTH, 404, 410, 422, s422="unknown metric (unknown_metric)"))
async def current_quality(
    s: SessionDep, reg: RegistryDep,
    metrics: Annotated[str | None, Query(max_length=400, json_schema_extra={"pattern": METRICS_PATTERN},
                                         description="comma-separated "
                                         f"subset of {list(METRICS)}; default all")] = None,
) -> dict[str, Any]:
    """Per-element metrics at the last MOVE, and summaries.

    One list per metric: tets in file order, then hexahedra, wedges and
    pyramids; null where a metric is for tets only.
    """
    names = list(METRICS) if metrics is None else [m.strip() for m in metrics.split(",") if m.strip()]
    bad = sorted(set(names) - set(METRICS))
    if bad or not names:
        raise ServiceError("unknown_metric", f"unknown metrics {bad}; choose from {list(METRICS)}",
                           unknown=bad, field="metrics")
    V = await reg.moves.positions(s)
    mesh = await reg.sessions.mesh(s)
    q = await reg.run(element_quality, V, mesh.T, mesh.cells)
    return {"elements": mesh.elements, "summary": summarize_quality({k: q[k] for k in names}),
            "per_element": {k: _json_floats(q[k]) for k in names}}


def _json_floats(x: np.ndarray) -> list[float | None]:
    """A float array as a JSON list, NaN (tet-only metrics on other elements) as null."""
    out = x.astype(object)
    out[~np.isfinite(x)] = None
    return out.tolist()


@router.get("/sessions/{session_id}/positions", summary="Current positions as JSON or binary",
            responses={200: {"content": {"application/json": {}, MEDIA_TYPE: {}}},
                       **error_responses(*_AUTH, 404, 410)})
async def current_positions(
    s: SessionDep, reg: RegistryDep,
    result: Annotated[Literal["json", "binary"], Query()] = "json",
    kind: Annotated[Kind, Query()] = "positions",
    dtype: Annotated[Dtype, Query()] = "float64",
) -> Response:
    """The current state, encoded like a deform result."""
    V = await reg.moves.positions(s)
    version = str(s.version)
    mesh = await reg.sessions.mesh(s)
    resp = result_response(V, mesh.V, s.report or {}, result, kind, dtype)
    resp.headers[VERSION_HEADER] = version
    return resp


@router.post("/sessions/{session_id}/reset", summary="Back to the rest shape", response_model=SessionDoc,
             responses=error_responses(*_AUTH, 404, 410))
async def reset(s: SessionDep, reg: RegistryDep) -> dict[str, Any]:
    """Forget the last MOVE; the factorization and the presets stay."""
    await reg.moves.reset(s)
    refresh_presets(reg.sessions, s)
    return doc_of(reg, s)


@router.delete("/sessions/{session_id}", status_code=204, summary="Delete a session",
               responses=error_responses(*_AUTH, 404, 410))
async def delete_session(s: SessionDep, reg: RegistryDep, request: Request) -> Response:
    """Drop the session, its factorization and its batch jobs (running ones are cancelled)."""
    request.app.state.jobs.end_session(s.id)
    await reg.sessions.delete(s)
    return Response(status_code=204)


__all__ = ["router", "result_response", "DeformJSON", "VERSION_HEADER"]
