"""``/v1/sessions/{id}/stream``: WebSocket for interactive drags, latest MOVE wins.

Client → server, text frames: ``{"seq": 7, "move": MOVE, "inversion": "warn", "repair": false}``
(or a bare MOVE). Server → client: for each solved MOVE a binary frame
(:mod:`service.binary`) whose header carries ``seq``, ``dropped`` (MOVEs
superseded while the previous one was solving) and a small REPORT; for a
MOVE that fails, a text frame ``{"seq": 7, "error": {...}}``. MOVEs that
arrive while one is being solved replace each other: only the newest is
solved next.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any, Literal

from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from solver.errors import SolverError

from ..binary import encode_frame
from ..errors import ServiceError, envelope, error_body
from ..registry import Registry

router = APIRouter(tags=["sessions"])

#: REPORT fields sent with each streamed frame.
STREAM_REPORT = ("inverted_elements", "degenerate_elements", "min_scaled_jacobian",
                 "constraint_residual_max", "max_displacement", "safe_fraction", "clamped",
                 "applied_fraction", "inverted_elements_unclamped", "conflicting_constraints", "repair")


@router.websocket("/sessions/{session_id}/stream")
async def stream(ws: WebSocket, session_id: str, kind: Literal["positions", "displacements"] =
                 "positions", dtype: Literal["float32", "float64"] = "float32") -> None:
    """Solve streamed MOVEs, dropping stale ones (close codes 4401 auth, 4404 unknown session)."""
    state = ws.app.state
    reg: Registry = state.registry
    try:
        owner = state.auth.owner(ws.headers, ws.query_params)
        s = reg.session(owner, session_id)
    except ServiceError as e:
        await ws.close(code=4000 + e.status, reason=e.message[:120])
        return
    await ws.accept()
    pending: dict[str, Any] | None = None
    dropped = 0
    wake = asyncio.Event()
    V0 = None

    async def receive() -> None:
        nonlocal pending, dropped
        while True:
            msg = await ws.receive()
            if msg["type"] == "websocket.disconnect":
                return
            text = msg.get("text")
            try:
                doc = json.loads(text) if text is not None else None
            except ValueError:
                doc = None
            if not isinstance(doc, dict):
                await ws.send_json({"seq": None, **envelope(
                    422, "invalid_message", "send text frames holding a JSON object {seq, move}")})
                continue
            if pending is not None:
                dropped += 1
            pending = doc
            wake.set()

    receiver = asyncio.create_task(receive())
    try:
        while True:
            waiter = asyncio.create_task(wake.wait())
            done, _ = await asyncio.wait({receiver, waiter}, return_when=asyncio.FIRST_COMPLETED)
            if receiver in done:
                waiter.cancel()
                return
            wake.clear()
            doc, pending = pending, None
            skipped, dropped = dropped, 0
            if doc is None:
                continue
            seq = doc.get("seq")
            move = doc["move"] if "move" in doc else {k: v for k, v in doc.items()
                                                        if k not in ("seq", "inversion", "repair")}
            try:
                rep_flag = doc.get("repair")
                if rep_flag is not None and not isinstance(rep_flag, bool):
                    raise ServiceError(422, "repair must be true or false", code="invalid_message")
                r = await reg.deform(s, move, doc.get("inversion"), "basic", rep_flag)
            except (SolverError, ServiceError) as e:
                await ws.send_json({"seq": seq, "dropped": skipped, **error_body(e)[1]})
                continue
            if V0 is None:
                V0 = (await reg.session_mesh(s)).V
            X = r.V if kind == "positions" else r.V - V0
            small = {k: r.report.get(k) for k in STREAM_REPORT}
            small["solve_ms"] = r.report["timings"]["update"]["total_ms"]
            await ws.send_bytes(encode_frame(X, {"seq": seq, "dropped": skipped, "report": small},
                                             dtype, kind))
    except (WebSocketDisconnect, RuntimeError):
        return  # the client went away mid-send
    finally:
        receiver.cancel()
