"""Documents of the service itself: health, readiness, formats, jobs."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

__all__ = ["Health", "Ready", "FormatInfo", "JobDoc"]


class Health(BaseModel):
    """Liveness and cache figures."""

    status: Literal["ok"]
    version: str
    sessions: int
    cached_sessions: int
    cache_bytes: int
    cache_budget_bytes: int
    evictions: int


class Ready(BaseModel):
    """Readiness: the data directory is writable and the workers are alive."""

    ready: bool
    checks: dict[str, bool] = Field(description="store_writable, workers, sweeper")


class FormatInfo(BaseModel):
    """One mesh format and what it keeps, measured by round trips of small meshes."""

    name: str = Field(description="format name for format= parameters")
    extension: str
    available: bool = Field(description="offered here (its libraries are installed and it round-trips)")
    needs: str | None = Field(description="the Python package it needs beyond meshio")
    read: bool
    write: bool
    sets: bool = Field(description="a node set survives writing and reading")
    quadratic: bool = Field(description="tetra10 elements survive")
    mixed: bool = Field(description="hexahedra next to pyramids survive")


class JobDoc(BaseModel):
    """A tetrahedralization job."""

    id: str
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    stage: str = Field(description="reading, tetrahedralizing, storing, done")
    progress: float = Field(description="0 to 1; fTetWild reports no finer progress")
    elapsed_s: float
    time_limit_s: float
    created: float
    error: dict[str, Any] | None = None
    mesh: dict[str, Any] | None = Field(None, description="the stored mesh when done")
