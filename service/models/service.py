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
    checks: dict[str, bool] = Field(description="store_writable, workers, sweeper, parse_workers (the "
                                    "processes that read uploaded files: false when a read is past its "
                                    "limits unstopped, no worker can be started, or more than twice as many "
                                    "files wait as there are workers, none of them idle)")


class FormatInfo(BaseModel):
    """One mesh format and what it keeps: measured by round trips of small meshes, or said by its reader."""

    name: str = Field(description="format name for format= parameters")
    extension: str = Field(description="the extension it is written with")
    available: bool = Field(description="offered here (its libraries are installed, and it round-trips or is "
                                        "written back in place)")
    needs: str | None = Field(description="the Python package it needs beyond meshio")
    read: bool = Field(description="meshes are uploaded in it")
    write: bool = Field(description="meshes of other formats are written in it (as converts_to)")
    sets: bool | None = Field(description="a node set survives writing and reading (null: not measured, the "
                                          "format is written back in place only)")
    quadratic: bool | None = Field(description="tetra10 elements survive (null: not measured)")
    mixed: bool | None = Field(description="hexahedra next to pyramids survive (null: not measured)")
    title: str = Field("", description="its name in words")
    extensions: list[str] = Field(default_factory=list, description="every extension that means it")
    in_place: bool = Field(False, description="a mesh read from it is written back to it in place: its file "
                                              "(and the files it includes) patched, only the coordinates of the "
                                              "nodes that moved changed")
    converts_to: bool = Field(False, description="a mesh read from another format is written in it; false for "
                                                 "a format written back only to decks read from it "
                                                 "(422 unwritable_format)")
    reads: str | None = Field(None, description="what its reader reads (formats with a reader of tetmorph's own)")
    refuses: str | None = Field(None, description="what its reader refuses, and how")


class JobDoc(BaseModel):
    """A job: a tetrahedralization, or a batch of plan rows on a session."""

    id: str
    kind: Literal["tetrahedralize", "batch", "study"] = "tetrahedralize"
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    stage: str = Field(description="a tetrahedralization: queued, starting (its worker process), "
                       "tetrahedralizing (fTetWild), checking (orienting and validating the tets), storing, done; "
                       "a batch: queued, solving, done; failed or cancelled")
    progress: float | None = Field(description="0 to 1: rows done / rows of a batch; for a tetrahedralization "
                                   "null until it is done (1): fTetWild reports no progress, so its stage and "
                                   "elapsed_s say where it is")
    stages: list[dict[str, Any]] | None = Field(None, description="a tetrahedralization's stages so far, in "
                                                "order: [{stage, at_s}], at_s the seconds since it started")
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
