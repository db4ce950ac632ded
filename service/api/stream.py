"""``/v1/sessions/{id}/stream``: WebSocket for interactive drags, latest MOVE wins.

Client → server, text frames: ``{"seq": 7, "move": MOVE, "inversion": "warn", "repair": false}``
(``move`` required, nothing else allowed). Server → client: for each solved MOVE a binary frame
(:mod:`service.binary`) whose header carries ``seq``, ``frame: "full"``, ``version`` (the
session's, after this MOVE's commit), ``dropped`` (MOVEs
superseded while the previous one was solving) and a small REPORT; for a
frame or MOVE that fails, a text frame ``{"seq": 7, "error": {...}}`` (the
session is unchanged). MOVEs that arrive while one is being solved replace
each other: only the newest is solved next.

With ``?frames=boundary`` (split solves) each MOVE first gets a ``frame:
"boundary"`` binary frame as soon as the boundary system is solved: the
positions (or displacements) of the boundary vertices only, in ascending
vertex order (the ``boundary`` flags of the geometry bundle), shape (b, 3);
then the ``full`` frame of the same ``seq`` with every vertex, the check and
the REPORT. A newer MOVE that arrives in between supersedes the pending
interior solve: its ``full`` frame is not sent and the MOVE is not committed.
Under the ``reject`` inversion policy no boundary frame is sent (the check,
which may refuse the MOVE, comes only with the full solve).

Close codes: 4400 two different API keys, 4401 no or unknown API key, 4403 a
browser page of another origin (``TETMORPH_ALLOWED_ORIGINS`` lists the ones
allowed), 4404 unknown session, 4410 expired session, 4422 an invalid query
parameter (``kind``, ``dtype``, ``frames``; closed by
:mod:`service.api.handlers`), 4429 too many connections of the key, 1013
(RFC 6455's "try again later") the session store (PostgreSQL) cannot be
reached when the stream opens, 1009 frame over the size limit, 1011 server
fault, each with a reason. A MOVE that meets a store outage once the stream is
open is answered like any failed MOVE (a text frame, ``store_unavailable``,
503); the stream stays open.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any, Literal

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from pydantic import ValidationError
from starlette.websockets import WebSocketState

from .. import strict_json
from ..binary import encode_frame
from ..errors import STORE_RETRY_AFTER_S, ServiceError, disk_full, error_body, status_of, store_outage
from ..middleware import lone_surrogate, may_hold_bad_text
from ..models.move import StreamFrame
from ..state.registry import Registry
from .handlers import validation_envelope

router = APIRouter(tags=["sessions"])
log = logging.getLogger("tetmorph.service")

#: REPORT fields sent with each streamed frame.
STREAM_REPORT = ("inverted_elements", "degenerate_elements", "min_scaled_jacobian",
                 "constraint_residual_max", "max_displacement", "safe_fraction", "clamped",
                 "applied_fraction", "inverted_elements_unclamped", "conflicting_constraints", "repair",
                 "finite")


def parse_frame(text: str | None, data: bytes | None, limit: int) -> StreamFrame:
    """A client frame as a :class:`StreamFrame`.

    Raises
    ------
    ServiceError
        ``invalid_message`` (not JSON, not an object, unknown fields, no
        ``move``, ...), ``duplicate_key`` (an object naming a key twice) or
        ``payload_too_large``.
    """
    size = len(text.encode()) if text is not None else len(data or b"")
    if size > limit:
        raise ServiceError("payload_too_large", f"frame of {size} bytes exceeds the limit of {limit} bytes",
                           bytes=size, limit=limit)
    if text is None:
        raise ServiceError("invalid_message", "send text frames holding a JSON object {seq, move}")
    try:
        doc = strict_json.loads(text)
    except (ValueError, RecursionError) as e:
        raise ServiceError("invalid_message", f"the frame is not JSON: {str(e)[:100]}") from None
    if not isinstance(doc, dict):
        raise ServiceError("invalid_message", "send text frames holding a JSON object {seq, move}")
    where = lone_surrogate(doc, "frame") if may_hold_bad_text(text) else None
    if where is not None:
        raise ServiceError("invalid_message", f"{where} holds a lone UTF-16 surrogate escape or NUL; text must be "
                           "valid Unicode without NUL", field=where)
    try:
        return StreamFrame.model_validate(doc)
    except ValidationError as e:
        env = validation_envelope(e.errors())["error"]
        raise ServiceError("invalid_message", env["message"].replace("invalid request", "invalid frame"),
                           **env["details"]) from None
    except RecursionError:
        raise ServiceError("invalid_message", "the frame is nested too deeply") from None


async def _close(ws: WebSocket, code: int, reason: str) -> None:
    if ws.application_state != WebSocketState.DISCONNECTED:
        try:
            await ws.close(code=code, reason=reason[:120])
        except RuntimeError:  # already closed by the peer
            pass


def origin_allowed(origin: str, host: str, allowed: list[str]) -> bool:
    """Whether a browser page of ``origin`` may open a stream: the service's own origin, or a listed one.

    A page of another site could otherwise drive a session on a service that
    trusts the network it listens on (no API keys): browsers send ``Origin``
    with every WebSocket handshake and do not apply the same-origin policy to it.
    """
    o = origin.strip().rstrip("/").lower()
    if o in {a.strip().rstrip("/").lower() for a in allowed}:
        return True
    scheme, sep, rest = o.partition("://")
    return bool(sep) and scheme in ("http", "https") and rest == host.strip().lower()


@router.websocket("/sessions/{session_id}/stream")
async def stream(ws: WebSocket, session_id: str, kind: Literal["positions", "displacements"] =
                 "positions", dtype: Literal["float32", "float64"] = "float32",
                 frames: Literal["full", "boundary"] = "full") -> None:
    """Solve streamed MOVEs, dropping stale ones (close codes in the module docstring)."""
    state = ws.app.state
    reg: Registry = state.registry
    origin = ws.headers.get("origin")
    if origin is not None and not origin_allowed(origin, ws.headers.get("host", ""), state.settings.allowed_origins):
        await ws.accept()  # then close, so that the page reads why
        await _close(ws, 4403, f"origin {origin[:60]!r} may not open streams (TETMORPH_ALLOWED_ORIGINS)")
        return
    try:
        owner = state.auth.owner(ws.headers, ws.query_params)
        s = reg.sessions.lookup(owner, session_id)
        slot = state.connections.acquire(owner)
    except Exception as e:  # noqa: BLE001 - every refusal reaches the client as a close code and a reason
        # closed before the handshake, a real server answers HTTP 403 and the code and reason are lost:
        # accept, then close, so the client reads 4401 / 4404 / 4410 / 4429 / 1013 and why
        await ws.accept()
        if isinstance(e, ServiceError):
            await _close(ws, 4000 + e.status, e.message)
        elif store_outage(e):
            await _close(ws, 1013, f"the session store cannot be reached: try again in {STORE_RETRY_AFTER_S} s")
        else:
            log.error("stream of session %s could not open", session_id, exc_info=e)
            await _close(ws, 1011, f"server error ({type(e).__name__})")
        return
    try:
        await ws.accept()
        await _serve(ws, reg, s, kind, dtype, state.settings.max_frame_bytes, frames == "boundary")
    except WebSocketDisconnect:
        pass
    except Exception as e:  # noqa: BLE001 - a server fault still closes with a code and reason
        log.error("stream of session %s failed", session_id, exc_info=e)
        await _close(ws, 1011, f"server error ({type(e).__name__})")
    finally:
        slot.release()


async def _serve(ws: WebSocket, reg: Registry, s: Any, kind: str, dtype: str, limit: int,
                 boundary_first: bool = False) -> None:
    pending: StreamFrame | None = None
    dropped = 0
    wake = asyncio.Event()
    V0 = None
    closing: list[tuple[int, str]] = []

    async def receive() -> None:
        nonlocal pending, dropped
        while True:
            msg = await ws.receive()
            if msg["type"] == "websocket.disconnect":
                return
            try:
                frame = parse_frame(msg.get("text"), msg.get("bytes"), limit)
            except ServiceError as e:
                if e.code == "payload_too_large":
                    closing.append((1009, e.message))
                    return
                await ws.send_json({"seq": None, **error_body(e)[1]})
                continue
            if pending is not None:
                dropped += 1
            pending = frame
            wake.set()

    receiver = asyncio.create_task(receive())
    try:
        while True:
            waiter = asyncio.create_task(wake.wait())
            done, _ = await asyncio.wait({receiver, waiter}, return_when=asyncio.FIRST_COMPLETED)
            if receiver in done:
                waiter.cancel()
                receiver.result()  # a failure of the receiver is a server fault
                if closing:
                    await _close(ws, *closing[0])
                return
            wake.clear()
            frame, pending = pending, None
            skipped, dropped = dropped, 0
            if frame is None:
                continue
            s.last_used = time.time()  # a streamed MOVE is activity
            if V0 is None:
                mesh = await reg.sessions.mesh(s)
                V0, on_boundary = mesh.V, mesh.boundary
            policy = frame.inversion or str(s.spec.get("inversion", "warn"))
            try:
                if boundary_first and policy != "reject":  # a rejected MOVE must never be drawn
                    t0 = time.perf_counter()
                    d, stage, move = await reg.moves.boundary_stage(s, frame.move)
                    if d.solve_mode == "split":
                        B = stage.P[on_boundary]
                        X = B if kind == "positions" else B - V0[on_boundary]
                        head = {"seq": frame.seq, "frame": "boundary", "dropped": skipped,
                                "solve_ms": 1e3 * (time.perf_counter() - t0)}
                        await ws.send_bytes(encode_frame(X, head, dtype, kind))
                        await asyncio.sleep(0)  # let a newer MOVE in
                        if pending is not None:  # superseded: its interior is never solved
                            continue
                    r = await reg.moves.complete_stage(s, d, stage, move, frame.inversion, frame.repair)
                else:
                    r = await reg.moves.deform(s, frame.move, frame.inversion, "basic", frame.repair)
            except Exception as e:  # noqa: BLE001 - every failed MOVE is answered, the session unchanged
                if status_of(e) >= 500 and not store_outage(e) and not disk_full(e):  # those: an error frame
                    raise
                if getattr(e, "code", None) == "session_not_found":  # deleted while streamed: the stream ends
                    await _close(ws, 4404, str(getattr(e, "message", e)))
                    return
                await ws.send_json({"seq": frame.seq, "dropped": skipped, **error_body(e)[1]})
                continue
            X = r.V if kind == "positions" else r.V - V0
            small = {k: r.report.get(k) for k in STREAM_REPORT}
            small["solve_ms"] = r.report["timings"]["update"]["total_ms"]
            await ws.send_bytes(encode_frame(X, {"seq": frame.seq, "frame": "full", "dropped": skipped,
                                                 "version": s.version, "report": small}, dtype, kind))
    finally:
        receiver.cancel()


__all__ = ["router", "parse_frame", "STREAM_REPORT"]
