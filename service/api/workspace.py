"""``/v1/meshes/{id}/workspace`` and ``/v1/sessions/{id}/workspace``: what a client shows beside them."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Body

from ..models.error import error_responses
from ..models.workspace import Workspace, WorkspaceDoc
from ..state.kept import load_workspace, save_workspace
from .deps import MeshDep, RegistryDep, SessionDep

router = APIRouter()
_AUTH = (401, 429)
_S422 = ("a bad workspace, naming the field (regions..., labels.k, doe_plan, shape_values..., session; too many "
         "or too large); the stored workspace is unchanged")


@router.get("/meshes/{mesh_id}/workspace", summary="The mesh's workspace", tags=["meshes"],
            response_model=WorkspaceDoc, responses=error_responses(*_AUTH, 404))
async def get_mesh_workspace(meta: MeshDep, reg: RegistryDep) -> dict[str, Any]:
    """What a client keeps with the mesh before (and between) sessions.

    The regions drawn, the session last opened on it. Empty until a client saves one; deleted
    with the mesh.
    """
    return load_workspace(reg.sessions, "mesh", meta["id"])


@router.put("/meshes/{mesh_id}/workspace", summary="Keep a workspace with the mesh", tags=["meshes"],
            response_model=WorkspaceDoc, responses=error_responses(*_AUTH, 404, 413, 422, s422=_S422))
async def put_mesh_workspace(
    meta: MeshDep, reg: RegistryDep,
    body: Annotated[Workspace, Body(description="replaces the mesh's workspace")],
) -> dict[str, Any]:
    """Replace the mesh's workspace; the mesh itself does not change.

    Every field may be left out: the whole workspace is replaced, a field left out by its empty
    value. Sizes and types are checked (at most 8 MiB of JSON); the regions are the client's
    draft, checked as a SPEC only when a session is created from them. A refused request stores
    nothing.
    """
    doc = body.dump()
    save_workspace(reg.sessions, "mesh", meta["id"], doc)
    return doc


@router.get("/sessions/{session_id}/workspace", summary="The session's workspace", tags=["sessions"],
            response_model=WorkspaceDoc, responses=error_responses(*_AUTH, 404, 410))
async def get_session_workspace(s: SessionDep, reg: RegistryDep) -> dict[str, Any]:
    """What a client shows beside the session.

    The regions drawn (they may be newer than the session's SPEC), the undo history's labels, the
    DOE plan and the shape values. Empty until a client saves one; it survives restarts and is
    deleted with the session.
    """
    return load_workspace(reg.sessions, "session", s.id, s)


@router.put("/sessions/{session_id}/workspace", summary="Keep a workspace with the session", tags=["sessions"],
            response_model=WorkspaceDoc, responses=error_responses(*_AUTH, 404, 410, 413, 422, s422=_S422))
async def put_session_workspace(
    s: SessionDep, reg: RegistryDep,
    body: Annotated[Workspace, Body(description="replaces the session's workspace")],
) -> dict[str, Any]:
    """Replace the session's workspace; the morph state does not change.

    The version, the last MOVE and the positions stay as they are.

    Every field may be left out: the whole workspace is replaced, a field left out by its empty
    value. Sizes and types are checked (at most 8 MiB of JSON); the regions are the client's
    draft, checked as a SPEC only when a session is created from them. A refused request stores
    nothing.
    """
    doc = body.dump()
    save_workspace(reg.sessions, "session", s.id, doc, s)
    return doc
