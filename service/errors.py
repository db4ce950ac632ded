"""Errors of the service: one JSON envelope, and one table from error to HTTP status.

Every non-2xx answer has the body::

    {"error": {"status": 422, "code": "inverted_elements", "type": "InversionError",
               "message": "...", "details": {...}}}

Solver errors keep their typed ``code`` and ``details`` (counts, ids, shapes).
The HTTP status of every error is decided here and nowhere else:
:data:`CODE_STATUS` by error code first, then :data:`TYPE_STATUS` by exception
type, else 500.
"""

from __future__ import annotations

import errno
import logging
import sys
from typing import Any

from solver.errors import (
    ConstraintError,
    FactorizationError,
    InvalidMeshError,
    InversionError,
    SolverError,
    SpecError,
)

__all__ = ["ServiceError", "NotFound", "CODE_STATUS", "TYPE_STATUS", "HTTP_CODES", "status_of",
           "envelope", "error_body", "error_from_dict", "disk_full", "retry_after", "error_record",
           "STORE_RETRY_AFTER_S", "STORAGE_RETRY_AFTER_S"]

log = logging.getLogger("tetmorph.service")

#: The HTTP status of each error code. Codes not listed take the status of their exception type.
CODE_STATUS: dict[str, int] = {
    # 401: who is asking
    "bad_request": 400,
    "invalid_host": 400,  # RFC 9112, section 3.2: an HTTP/1.1 request without Host, or with two
    "conflicting_credentials": 400,  # two API keys in one request
    "missing_api_key": 401, "invalid_api_key": 401,
    # 404: unknown resources (or another key's), unknown routes
    "mesh_not_found": 404, "session_not_found": 404, "job_not_found": 404, "not_found": 404,
    "method_not_allowed": 405,
    # 409: the resource's state forbids the request
    "mesh_in_use": 409, "session_exists": 409, "job_finished": 409,
    "version_conflict": 409,  # another replica committed first: retry (docs/guide/cluster.md)
    "job_not_finished": 409,
    # 410: a session removed after its idle time
    "session_expired": 410,
    "payload_too_large": 413,
    # 422: the request's documents, files or parameters
    "invalid_request": 422, "invalid_message": 422, "unknown_format": 422, "unknown_metric": 422,
    "too_many_elements": 422, "too_many_triangles": 422, "non_finite_result": 422,
    "out_of_range": 422, "index_out_of_range": 422, "job_time_limit": 422, "solve_option_not_allowed": 422,
    "surface_not_found": 422, "not_a_surface": 422, "too_many_rows": 422, "engine_unavailable": 422,
    "result_too_large": 422, "bounds_time_limit": 422, "solver_unavailable": 422, "duplicate_file_name": 422,
    "duplicate_key": 422,  # a JSON object names a key twice (service/strict_json.py)
    "parse_time_limit": 422, "parse_cpu_limit": 422,  # a file's read stopped (service/state/parse_pool.py)
    "unused_points": 422,  # an upload of nodes no element uses (service/state/reads.py)
    "not_a_volume_mesh": 422,  # a quality check of a triangle surface (service/api/check.py)
    "parse_memory_limit": 413,
    # 431: a request head over TETMORPH_MAX_HEADER_KB or TETMORPH_MAX_HEADERS (service/http_protocol.py)
    "headers_too_large": 431,
    # 429: limits per key
    "rate_limited": 429, "session_limit": 429, "connection_limit": 429, "parse_queue_full": 429,
    # 5xx: faults of the server, never of the request
    "internal_error": 500, "build_failed": 500, "worker_failed": 500,
    "unknown_backend": 500,  # TETMORPH_SOLVER names a backend this installation lacks
    "unavailable": 503,  # the service is stopping
    # 507: a write of the data directory failed for want of space (ENOSPC, EDQUOT): nothing was stored
    "storage_full": 507,
}

#: The HTTP status by exception type, for codes not in :data:`CODE_STATUS` (first match wins).
TYPE_STATUS: tuple[tuple[type[BaseException], int], ...] = (
    (InversionError, 422),  # policy 'reject' and an inverting MOVE
    (ConstraintError, 422),  # constraints undetermined or conflicting
    (SpecError, 422),  # malformed SPEC or MOVE
    (InvalidMeshError, 422),  # the uploaded mesh or surface
    (FactorizationError, 422),  # a singular system: what the SPEC leaves unconstrained
    (SolverError, 422),
)

#: Error code of a bare HTTP status (routing errors, middleware answers).
HTTP_CODES: dict[int, str] = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found",
                              405: "method_not_allowed", 406: "not_acceptable", 409: "conflict",
                              410: "gone", 413: "payload_too_large", 415: "unsupported_media_type",
                              422: "invalid_request", 429: "too_many_requests", 500: "internal_error",
                              503: "unavailable"}


class ServiceError(Exception):
    """An error of the service with a stable code and JSON details.

    Its HTTP status comes from :data:`CODE_STATUS`.

    Parameters
    ----------
    code : str
        A key of :data:`CODE_STATUS`.
    message : str
    **details
        JSON-serialisable facts backing the message.

    Examples
    --------
    >>> ServiceError("session_limit", "too many").status
    429
    """

    def __init__(self, code: str, message: str, **details: Any) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.details = details
        self.headers: dict[str, str] = {}

    @property
    def status(self) -> int:
        """The HTTP status of this error."""
        return status_of(self)


class NotFound(ServiceError):
    """A resource that does not exist, or belongs to another API key."""

    def __init__(self, kind: str, ident: str) -> None:
        super().__init__(f"{kind}_not_found", f"no {kind} with id {ident!r}", **{f"{kind}_id": ident})


#: Seconds a client is asked to wait (``Retry-After``) when the session store is unreachable.
STORE_RETRY_AFTER_S = 1

#: Seconds a client is asked to wait (``Retry-After``) when the data directory is full (507 ``storage_full``):
#: long enough for an operator or a cleanup to free space, short enough for an interactive client to retry.
STORAGE_RETRY_AFTER_S = 30

#: ``errno`` of a write refused for want of space: the device is full, or the owner's disk quota is spent.
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})


def disk_full(e: BaseException) -> bool:
    """Whether ``e`` is a write refused for want of space: an ``OSError`` with ``ENOSPC`` or ``EDQUOT``.

    An exception raised *from* such an error (``raise ... from e``) counts too, unless it is a
    service or solver error: those keep their own code.

    Examples
    --------
    >>> import errno
    >>> disk_full(OSError(errno.ENOSPC, "No space left on device")), disk_full(OSError(errno.EACCES, "denied"))
    (True, False)
    """
    return _disk_error(e) is not None


def _disk_error(e: BaseException) -> OSError | None:
    """The ``ENOSPC`` or ``EDQUOT`` error ``e`` is or was raised from, or None."""
    seen: BaseException | None = e
    for _ in range(8):  # a chain of causes is short; never follow a cycle for long
        if seen is None or isinstance(seen, (ServiceError, SolverError)):
            return None
        if isinstance(seen, OSError) and seen.errno in DISK_FULL_ERRNOS:
            return seen
        seen = seen.__cause__
    return None


def store_outage(e: BaseException) -> bool:
    """Whether ``e`` says the database cannot be reached (psycopg's operational and interface errors).

    psycopg is imported only by the PostgreSQL store: when it is not loaded, nothing is an outage.
    """
    psycopg = sys.modules.get("psycopg")
    return psycopg is not None and isinstance(e, (psycopg.OperationalError, psycopg.InterfaceError))


def status_of(e: BaseException) -> int:
    """The HTTP status of an exception: by its code, then by its type, else 500.

    Examples
    --------
    >>> status_of(SpecError("bad")), status_of(FactorizationError("x", code="unknown_backend"))
    (422, 500)
    >>> status_of(KeyError("x"))
    500
    """
    code = getattr(e, "code", None)
    if isinstance(code, str) and code in CODE_STATUS:
        return CODE_STATUS[code]
    if disk_full(e):
        return CODE_STATUS["storage_full"]
    if store_outage(e):
        return 503
    for kind, status in TYPE_STATUS:
        if isinstance(e, kind):
            return status
    return 500


def envelope(status: int, code: str, message: str, details: dict[str, Any] | None = None,
             type_: str | None = None) -> dict[str, Any]:
    """Build the error body."""
    return {"error": {"status": status, "code": code, "type": type_ or "ServiceError",
                      "message": message, "details": details or {}}}


def error_body(e: BaseException) -> tuple[int, dict[str, Any]]:
    """HTTP status and envelope of any exception (HTTP responses and WebSocket frames).

    Unexpected exceptions are logged with their traceback and answered with a
    generic message that names the exception type only.
    """
    status = status_of(e)
    if isinstance(e, (ServiceError, SolverError)):
        return status, envelope(status, e.code, e.message, e.details, type(e).__name__)
    if status == 507:  # the data directory is full: the write failed whole, what was stored before is intact
        return status, storage_full_body(e)
    if status == 503:  # the database is down or restarting: nothing was stored, the request can be sent again
        log.warning("session store unreachable: %s", type(e).__name__)
        return 503, envelope(503, "store_unavailable", "the session store (PostgreSQL) cannot be reached; "
                             f"nothing was stored: retry after {STORE_RETRY_AFTER_S} s",
                             {"retry_after_s": STORE_RETRY_AFTER_S})
    log.error("unhandled error", exc_info=e)
    return 500, envelope(500, "internal_error", f"internal error ({type(e).__name__})",
                         {"exception": type(e).__name__})


def storage_full_body(e: BaseException) -> dict[str, Any]:
    """The envelope of a write refused for want of space (507 ``storage_full``); no path of the server is named."""
    os_error = _disk_error(e)
    number = os_error.errno if os_error is not None and os_error.errno is not None else errno.ENOSPC
    name = errno.errorcode.get(number, str(number))
    reason = "the disk quota of the service is spent" if number == errno.EDQUOT else "no space is left on its disk"
    log.warning("a write of the data directory failed: %s (%s)", name, os_error)
    return envelope(507, "storage_full", f"the data directory is full ({reason}); nothing was stored and what was "
                    "stored before is intact: free space in the data directory (TETMORPH_DATA_DIR) or grow its "
                    f"volume, then retry after {STORAGE_RETRY_AFTER_S} s", {"errno": name,
                                                                         "retry_after_s": STORAGE_RETRY_AFTER_S},
                    type(os_error if os_error is not None else e).__name__)


def retry_after(status: int, code: str) -> int | None:
    """Seconds of the ``Retry-After`` header of an error answer, or None when there is none.

    A full data directory (507 ``storage_full``) asks for :data:`STORAGE_RETRY_AFTER_S`; an unreachable
    store or a stopping service (503) for :data:`STORE_RETRY_AFTER_S`.

    Examples
    --------
    >>> retry_after(507, "storage_full"), retry_after(503, "store_unavailable"), retry_after(500, "internal_error")
    (30, 1, None)
    """
    if code == "storage_full":
        return STORAGE_RETRY_AFTER_S
    if status == 503:
        return STORE_RETRY_AFTER_S
    return None


def error_record(e: BaseException, default_code: str = "worker_failed") -> dict[str, Any]:
    """``{"type", "code", "message", "details"}`` of an error a job failed with (:func:`error_from_dict` reads it).

    A write refused for want of space is ``storage_full``; another error keeps its code, else ``default_code``.
    """
    if disk_full(e):
        body = storage_full_body(e)["error"]
        return {k: body[k] for k in ("type", "code", "message", "details")}
    return {"type": type(e).__name__, "code": getattr(e, "code", default_code),
            "message": getattr(e, "message", str(e)), "details": getattr(e, "details", {})}


def error_from_dict(doc: dict[str, Any], prefix: str = "") -> Exception:
    """Rebuild an error recorded as ``{"type", "code", "message", "details"}`` (a failed build or job).

    Solver errors come back as their own type, so their status is theirs.

    Examples
    --------
    >>> e = error_from_dict({"type": "SpecError", "code": "empty_selection", "message": "m", "details": {}})
    >>> type(e).__name__, status_of(e)
    ('SpecError', 422)
    """
    import solver.errors as se

    code, msg, details = doc.get("code"), prefix + str(doc.get("message", "")), dict(doc.get("details") or {})
    cls = getattr(se, str(doc.get("type", "")), None)
    if isinstance(cls, type) and issubclass(cls, SolverError) and cls is not InversionError:
        return cls(msg, code=code, **details)
    if isinstance(code, str) and code in CODE_STATUS:
        return ServiceError(code, msg, **details)
    return ServiceError("internal_error", msg, **details)
