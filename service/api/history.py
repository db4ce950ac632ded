"""``/v1/sessions/{id}/history``: the undo history a client keeps with a session."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Body

from ..models.error import error_responses
from ..models.history import History, HistoryDoc
from ..state.kept import load_history, save_history
from .deps import RegistryDep, SessionDep

router = APIRouter(tags=["sessions"])
_AUTH = (401, 429)


@router.get("/sessions/{session_id}/history", summary="The session's undo history", response_model=HistoryDoc,
            responses=error_responses(*_AUTH, 404, 410))
async def get_history(s: SessionDep, reg: RegistryDep) -> dict[str, Any]:
    """The MOVEs a client applied to the session, and those it undid since.

    ``{"applied": [], "undone": []}`` until a client saves one. The editor keeps its
    undo and redo here, so they survive a reload, a reopen from another
    browser, a restart of the service and a failover to another replica.
    """
    return load_history(reg.sessions, s)


@router.put("/sessions/{session_id}/history", summary="Keep the undo history with the session",
            response_model=HistoryDoc, responses=error_responses(
                *_AUTH, 404, 410, 413, 422,
                s422="a bad history, naming the field (applied[k]..., undone[k]..., too many or too "
                     "large); the stored history is unchanged"))
async def put_history(
    s: SessionDep, reg: RegistryDep,
    body: Annotated[History, Body(description="replaces the session's history")],
) -> dict[str, Any]:
    """Replace the session's undo history; every MOVE is validated as a deform's MOVE is.

    It is not the morph state: the version, the last MOVE and the positions
    do not change (apply a MOVE with POST .../deform), and a MOVE being
    solved meanwhile commits as usual.
    """
    doc = body.dump()
    save_history(reg.sessions, s, doc)
    return doc
