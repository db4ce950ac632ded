"""The JSON error envelope every non-2xx answer carries."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["ErrorBody", "ErrorEnvelope", "error_responses"]


class ErrorBody(BaseModel):
    """What went wrong, with a stable machine-readable code."""

    status: int = Field(description="the HTTP status, repeated")
    code: str = Field(description="stable identifier, e.g. 'session_not_found', 'inverted_elements'")
    type: str = Field(description="the error's class, e.g. 'SpecError', 'ServiceError'")
    message: str = Field(description="what is wrong, naming fields, counts and the first offending ids")
    details: dict[str, Any] = Field(default_factory=dict, description="facts backing the message")


class ErrorEnvelope(BaseModel):
    """``{"error": {...}}``: the body of every error answer."""

    model_config = ConfigDict(json_schema_extra={"examples": [{"error": {
        "status": 404, "code": "session_not_found", "type": "NotFound",
        "message": "no session with id 's_0123'", "details": {"session_id": "s_0123"}}}]})

    error: ErrorBody


_WHY = {
    401: "no API key, or an unknown one (codes missing_api_key, invalid_api_key)",
    404: "unknown resource, or one of another API key (codes mesh_not_found, session_not_found, ...)",
    409: "the resource's state forbids it (mesh_in_use, session_exists, ...)",
    410: "the session was removed after its idle time (session_expired)",
    413: "request body over MAX_UPLOAD_MB (payload_too_large)",
    422: "invalid request: the error names the field (invalid_request, invalid_spec, unknown_format, ...)",
    429: "rate limit or session limit of the key (rate_limited with Retry-After, session_limit)",
    500: "a fault of the server (internal_error, build_failed, unknown_backend); the request is not at fault",
    503: "the service is not ready (unavailable)",
}


def error_responses(*statuses: int, **why: str) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` entries with the error envelope for the given statuses.

    Parameters
    ----------
    *statuses : int
    **why : str
        Route-specific descriptions, keyed ``s422=...``.

    Examples
    --------
    >>> sorted(error_responses(404, 422))
    [404, 422]
    """
    return {s: {"model": ErrorEnvelope, "description": why.get(f"s{s}", _WHY.get(s, "error"))}
            for s in statuses}
