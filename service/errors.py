"""One JSON error envelope for every error the service returns.

Every non-2xx answer has the body::

    {"error": {"status": 422, "code": "inverted_elements", "type": "InversionError",
               "message": "...", "details": {...}}}

Solver errors keep their typed ``code`` and ``details`` (counts, ids, shapes).
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from solver.errors import SolverError

__all__ = ["ServiceError", "NotFound", "envelope", "error_body", "error_response",
           "install_handlers"]

log = logging.getLogger("tetmorph.service")

_HTTP_CODES = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found",
               405: "method_not_allowed", 406: "not_acceptable", 409: "conflict",
               413: "payload_too_large", 415: "unsupported_media_type", 422: "unprocessable",
               429: "too_many_requests", 500: "internal_error", 503: "unavailable"}


class ServiceError(Exception):
    """An error with an HTTP status, a stable code and JSON details.

    Parameters
    ----------
    status : int
    message : str
    code : str, optional
    **details
        JSON-serialisable facts backing the message.
    """

    def __init__(self, status: int, message: str, code: str | None = None, **details: Any) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.code = code or _HTTP_CODES.get(status, "error")
        self.details = details
        self.headers: dict[str, str] = {}


class NotFound(ServiceError):
    """A resource that does not exist, or belongs to another API key."""

    def __init__(self, kind: str, ident: str) -> None:
        super().__init__(404, f"no {kind} with id {ident!r}", code=f"{kind}_not_found",
                         **{f"{kind}_id": ident})


def envelope(status: int, code: str, message: str, details: dict[str, Any] | None = None,
             type_: str | None = None) -> dict[str, Any]:
    """Build the error body."""
    return {"error": {"status": status, "code": code, "type": type_ or "ServiceError",
                      "message": message, "details": details or {}}}


def error_body(e: Exception) -> tuple[int, dict[str, Any]]:
    """HTTP status and envelope of any exception (HTTP responses and WebSocket frames)."""
    if isinstance(e, ServiceError):
        return e.status, envelope(e.status, e.code, e.message, e.details, type(e).__name__)
    if isinstance(e, SolverError):
        # every solver error is a defect of the request's mesh, SPEC or MOVE
        return 422, envelope(422, e.code, e.message, e.details, type(e).__name__)
    log.exception("unhandled error", exc_info=e)
    return 500, envelope(500, "internal_error", f"internal error: {type(e).__name__}: {e}")


def error_response(e: Exception) -> JSONResponse:
    """Map any exception to a JSONResponse carrying the envelope."""
    status, body = error_body(e)
    return JSONResponse(body, status_code=status, headers=getattr(e, "headers", None))


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
        code = _HTTP_CODES.get(e.status_code, "error")
        msg = e.detail if isinstance(e.detail, str) else code.replace("_", " ")
        if e.status_code == 404 and msg == "Not Found":
            msg = f"no route {request.method} {request.url.path}"
        return JSONResponse(envelope(e.status_code, code, msg), status_code=e.status_code,
                            headers=getattr(e, "headers", None))

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, e: RequestValidationError) -> JSONResponse:
        errors = [{"loc": [str(x) for x in err.get("loc", ())], "msg": err.get("msg", ""),
                   "type": err.get("type", "")} for err in e.errors()]
        where = "; ".join(f"{'.'.join(x['loc'])}: {x['msg']}" for x in errors[:5])
        return JSONResponse(envelope(422, "invalid_request", f"invalid request: {where}",
                                     {"errors": errors}, "RequestValidationError"),
                            status_code=422)

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, e: Exception) -> JSONResponse:
        return error_response(e)
