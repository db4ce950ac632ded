"""Exception handlers: every error becomes the JSON envelope of :mod:`service.errors`.

A stream (WebSocket) whose query parameters are invalid is accepted, then closed with
:data:`STREAM_INVALID_QUERY` and a reason naming each parameter and its allowed values.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from fastapi import FastAPI, Request, WebSocket
from fastapi.exceptions import RequestValidationError, WebSocketRequestValidationError
from pydantic import BaseModel
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from solver.documents.move import Move
from solver.documents.spec import Spec
from solver.documents.validation import validated
from solver.errors import SolverError, SpecError

from ..errors import HTTP_CODES, ServiceError, envelope, error_body, retry_after
from .responses import JSONResponse

__all__ = ["install_handlers", "error_response", "validation_envelope", "document_error", "stream_query_reason",
           "STREAM_INVALID_QUERY"]

#: Close code of a stream opened with an invalid query parameter (4000 + the status of ``invalid_request``).
STREAM_INVALID_QUERY = 4422


def error_response(e: BaseException) -> JSONResponse:
    """Map any exception to a JSONResponse carrying the envelope."""
    status, body = error_body(e)
    headers = getattr(e, "headers", None)
    wait = retry_after(status, body["error"]["code"])  # a store out of reach (503), a full data directory (507)
    if wait is not None:
        headers = {"Retry-After": str(wait), **(headers or {})}
    return JSONResponse(body, status_code=status, headers=headers)


def _got(err: Any) -> str:
    if "input" not in err or isinstance(err["input"], (dict, list)) or err.get("type") == "missing":
        return ""
    text = repr(err["input"])
    return f", got {text[:60]}{'...' if len(text) > 60 else ''}"


def validation_envelope(errors: Sequence[Any]) -> dict[str, Any]:
    """The envelope of request validation errors, each naming its field and the value given."""
    out = [{"loc": [str(x) for x in err.get("loc", ())],
            "msg": str(err.get("msg", "")) + _got(err), "type": str(err.get("type", ""))} for err in errors]
    where = "; ".join(f"{'.'.join(x['loc'])}: {x['msg']}" for x in out[:5])
    return envelope(422, "invalid_request", f"invalid request: {where}", {"errors": out},
                    "RequestValidationError")


#: The solver's documents a request body may be or hold, by the name the library's errors give them.
_DOCUMENTS: dict[str, type[BaseModel]] = {"MOVE": Move, "SPEC": Spec}


def document_error(route: Any, errors: Sequence[Any], body: Any) -> SpecError | None:
    """The library's error for a request body that is, or holds, a SPEC or MOVE; None for any other body.

    A bad MOVE (or SPEC) answers the code, field and message the library gives it
    (``invalid_spec``, ``MOVE.handles.tip.translation``), whether the request's validation or
    the library found it; the body is validated again by the library's own function for that.
    ``route`` is the matched route (its ``body_field``); ``errors`` the request's validation errors.
    """
    locs = [tuple(err.get("loc", ())) for err in errors]
    if not locs or any(len(loc) < 1 or loc[0] != "body" for loc in locs):
        return None
    field = getattr(route, "body_field", None)
    model = getattr(getattr(field, "field_info", None), "annotation", None)
    what = next((name for name, cls in _DOCUMENTS.items() if model is cls), None)
    doc = body
    if what is None and isinstance(model, type) and issubclass(model, BaseModel) and isinstance(body, dict):
        members = {loc[1] for loc in locs if len(loc) > 1}
        if len(members) != 1 or len(locs) != sum(len(loc) > 1 for loc in locs):
            return None
        member = members.pop()
        info = model.model_fields.get(str(member))
        what = next((name for name, cls in _DOCUMENTS.items() if getattr(info, "annotation", None) is cls), None)
        doc = body.get(member)
    if what is None:
        return None
    try:
        validated(_DOCUMENTS[what], doc, what)
    except SpecError as err:
        return err
    return None  # the document is valid: the errors lie elsewhere in the body


def stream_query_reason(errors: Sequence[Any], limit: int = 123) -> str:
    """The close reason of an invalid stream query: each parameter, the value given and what it may be.

    At most ``limit`` bytes of UTF-8, the most a WebSocket close frame carries.

    Examples
    --------
    >>> stream_query_reason([{"loc": ("query", "kind"), "input": "velocity",
    ...                       "msg": "Input should be 'positions' or 'displacements'"}])
    "invalid query parameter kind='velocity': input should be 'positions' or 'displacements'"
    """
    parts = []
    for err in errors:
        name = str(list(err.get("loc", ()))[-1]) if err.get("loc") else "?"
        given = repr(err["input"])[:20] if isinstance(err.get("input"), (str, int, float)) else "?"
        msg = str(err.get("msg", "invalid"))
        parts.append(f"{name}={given}: {msg[:1].lower()}{msg[1:]}")
    text = "invalid query parameter " + "; ".join(parts)
    return text.encode()[:limit].decode(errors="ignore")


#: The methods a route of the API may have.
_METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE")


def allowed_methods(request: Request) -> list[str]:
    """Every method some route answers on the request's path (routers nest, so each method is tried)."""
    routes = request.app.router.routes
    allowed = []
    for method in _METHODS:
        scope = {**request.scope, "method": method}
        if any(route.matches(scope)[0] is Match.FULL for route in routes):
            allowed.append(method)
    return allowed


def install_handlers(app: FastAPI) -> None:
    """Register the envelope for service, solver, HTTP, validation and unexpected errors."""

    @app.exception_handler(ServiceError)
    async def _service(request: Request, e: ServiceError) -> JSONResponse:
        return error_response(e)

    @app.exception_handler(SolverError)
    async def _solver(request: Request, e: SolverError) -> JSONResponse:
        return error_response(e)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, e: StarletteHTTPException) -> JSONResponse:
        code = HTTP_CODES.get(e.status_code, "error")
        msg = e.detail if isinstance(e.detail, str) else code.replace("_", " ")
        if e.status_code == 404 and msg == "Not Found":
            msg = f"no route {request.method} {request.url.path}"
        headers = getattr(e, "headers", None)
        if e.status_code == 405:  # every route of the path, not only the first that matched it
            allowed = allowed_methods(request)
            headers = {**(headers or {}), "Allow": ", ".join(allowed)}
            msg = f"{request.method} is not allowed on {request.url.path}; allowed: {', '.join(allowed)}"
        return JSONResponse(envelope(e.status_code, code, msg), status_code=e.status_code, headers=headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, e: RequestValidationError) -> JSONResponse:
        found = document_error(request.scope.get("route"), list(e.errors()), e.body)
        if found is not None:  # a SPEC or MOVE: the library's code and field
            return error_response(found)
        return JSONResponse(validation_envelope(list(e.errors())), status_code=422)

    @app.exception_handler(WebSocketRequestValidationError)
    async def _stream_query(ws: WebSocket, e: WebSocketRequestValidationError) -> None:
        # closed before the handshake, a real server answers HTTP 403 and the reason is lost:
        # accept, then close, so that the client reads which parameter and what it may be
        await ws.accept()
        await ws.close(code=STREAM_INVALID_QUERY, reason=stream_query_reason(list(e.errors())))
