"""Session documents."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from ..state.session import SessionStatus
from .report import Report

__all__ = ["SessionDoc"]


class SessionDoc(BaseModel):
    """A session: its status, progress, set-up figures and the last MOVE and REPORT."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "id": "s_0a1b2c3d4e5f6071", "mesh_id": "m_3f9c0a1b2d4e6f70", "status": "ready", "stage": "done",
        "progress": 1.0, "error": None, "created": 1764579600.0, "last_used": 1764579660.0,
        "expires_at": 1764666060.0, "updates": 1, "builds": 1, "handles": ["tip"],
        "last_move": {"handles": {"tip": {"translation": [0, 0, 4]}}}, "spec": {}, "setup_timings": None,
        "factor_bytes": 1048576, "constraints_at_rest": None, "last_report": None}]})

    id: str
    mesh_id: str
    status: SessionStatus
    stage: str = Field(description="build stage while building")
    progress: float = Field(description="build progress, 0 to 1")
    error: dict[str, Any] | None = Field(description="why the build failed (status 'failed')")
    created: float
    last_used: float = Field(description="Unix time of the last authenticated use")
    expires_at: float | None = Field(description="when the session is removed if unused until then")
    updates: int
    builds: int
    handles: list[str]
    last_move: dict[str, Any] | None = Field(description="the committed MOVE (as applied, when clamped)")
    version: int = Field(0, description="committed MOVEs (and resets) of the session so far")
    spec: dict[str, Any]
    setup_timings: dict[str, Any] | None
    factor_bytes: int | None
    constraints_at_rest: dict[str, Any] | None
    last_report: Report | None
