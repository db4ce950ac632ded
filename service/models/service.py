"""Documents of the service itself: health, readiness, formats, jobs."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

__all__ = ["Health", "Ready", "FormatInfo", "JobDoc"]


class Health(BaseModel):
    """Liveness and cache figures."""

    status: Literal["ok"]
    version: str
    replica: str = Field(description="this replica's id (TETMORPH_REPLICA_ID)")
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
    """A job: a tetrahedralization, or a batch of plan rows on a session."""

    id: str
    kind: Literal["tetrahedralize", "batch", "study"] = "tetrahedralize"
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    stage: str = Field(description="reading, tetrahedralizing, storing, solving, done")
    progress: float = Field(description="0 to 1: rows done / rows of a batch; fTetWild reports no finer progress")
    elapsed_s: float
    time_limit_s: float
    created: float
    error: dict[str, Any] | None = None
    mesh: dict[str, Any] | None = Field(None, description="the stored mesh when done (tetrahedralize)")
    session_id: str | None = Field(None, description="the session of a batch")
    rows_done: int | None = Field(None, description="plan rows solved so far (batch)")
    rows_total: int | None = Field(None, description="plan rows (batch)")
    summary: dict[str, Any] | None = Field(None, description="variants ok / rejected / conflict, engine, timings "
                                           "(a study: rows per status)")
    result: str | None = Field(None, description="where to GET the zip when done: decks and summary.csv "
                               "(batch); each row's folder and study.csv (study)")
