"""Service settings, read from ``TETMORPH_*`` environment variables or arguments.

Examples
--------
>>> s = Settings(api_keys="alpha, beta", data_dir="/tmp/tm")
>>> s.api_keys
['alpha', 'beta']
"""

from __future__ import annotations

import os
import socket
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from solver import options as solver_options
from solver.io.bounds import ReadBounds
from solver.limits import MAX_CELLS, MAX_EXPANDED_BYTES, MAX_POINTS
from solver.options import SolveOptions

__all__ = ["Settings"]


def _default_data_dir() -> Path:
    base = os.environ.get("XDG_DATA_HOME") or os.path.join(os.path.expanduser("~"), ".local", "share")
    return Path(base) / "tetmorph"


class Settings(BaseSettings):
    """Configuration of one tetmorph service instance.

    Every field can be set by an environment variable of the same name in
    upper case with the prefix ``TETMORPH_`` (``TETMORPH_API_KEYS=a,b``).
    """

    model_config = SettingsConfigDict(env_prefix="TETMORPH_", extra="ignore")

    data_dir: Path = Field(default_factory=_default_data_dir,
                           description="Where meshes and sessions persist across restarts.")
    min_free_mb: float = Field(64.0, ge=0, description="Free space the data directory's disk keeps in reserve: "
                               "with less, GET /ready answers 503 (store_writable false) so that a load "
                               "balancer sends no more writes; 0 checks none. A write that finds the disk full "
                               "answers 507 storage_full, stores nothing and leaves what was stored intact.")
    api_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Accepted API keys (comma separated). Empty: no authentication, one tenant.")
    allowed_origins: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Web origins (scheme://host:port, comma separated) whose pages may open a session's "
                    "stream, besides the service's own. A browser's WebSocket from any other page is closed "
                    "with 4403; clients that send no Origin (scripts, the Python client) are not affected.")
    max_upload_mb: float = Field(200.0, gt=0, description="Largest request body (413 above).")
    max_file_points: int = Field(MAX_POINTS, gt=0, le=MAX_POINTS, description="Most nodes an uploaded file "
                                 "may declare; checked from its header before anything is read or "
                                 "decompressed (422 too_many_points).")
    max_file_cells: int = Field(MAX_CELLS, gt=0, le=MAX_CELLS, description="Most elements an uploaded file "
                                "may declare; checked as max_file_points (422 too_many_cells).")
    max_file_expanded_mb: float = Field(
        1024.0, gt=0, le=MAX_EXPANDED_BYTES / 2**20,
        description="Most MiB a mesh file's data arrays may take once read, in all: compressed arrays (VTU "
                    "zlib/LZMA blocks, HDF5 datasets of XDMF, CGNS) from their headers before anything is "
                    "decompressed and again while decompressing, uncompressed tables (legacy VTK, TetGen) from "
                    "their declared counts (422 too_many_bytes). The default holds far more than "
                    "max_elements; it applies to stored meshes when they are read back too.")
    head_timeout_s: float = Field(10.0, gt=0, description="Longest a client may take to send a request's "
                                  "line and headers, or may pause in its body (which must also average "
                                  "1 KiB/s after that long); a slower connection is closed (tetmorph serve).")
    http_impl: Literal["auto", "httptools", "h11"] = Field(
        "auto", description="HTTP/1.1 parser of tetmorph serve: httptools (auto, a dependency of the service "
                            "extra) or h11; both apply head_timeout_s to request heads and bodies, and "
                            "max_header_kb and max_headers to request heads.")
    max_header_kb: float = Field(64.0, gt=0, description="Largest request head, request line and headers "
                                 "together; a larger one is answered 431 headers_too_large as soon as that much "
                                 "has come, and its connection closed (tetmorph serve).")
    max_headers: int = Field(100, gt=0, description="Most header lines of a request (431 headers_too_large "
                             "above, as max_header_kb).")
    max_elements: int = Field(5_000_000, gt=0, description="Most volume elements per mesh (422 above).")
    max_sessions: int = Field(64, gt=0, description="Most live sessions per API key (429 above).")
    rate_limit_per_s: float = Field(200.0, ge=0,
                                    description="Sustained requests per second per key; 0 disables.")
    rate_burst: int = Field(400, gt=0, description="Requests a key may send at once.")
    cache_budget_mb: float = Field(4096.0, gt=0,
                                   description="Memory for cached factorizations (LRU by size).")
    session_ttl_s: float = Field(24 * 3600.0, gt=0,
                                 description="Idle sessions older than this are removed.")
    build_wait_s: float = Field(1.0, ge=0,
                                description="How long session creation waits before answering 202.")
    build_workers: int = Field(1, gt=0, description="Threads that assemble and factor.")
    solve_workers: int = Field(0, ge=0, description="Threads that solve MOVEs at once (0: one per core). "
                               "Each solve shares the cores free when it starts with the solves in flight, so "
                               "more workers mean fewer threads per solve, never more threads than cores.")
    solve_backend: Literal["auto", "cholmod", "pardiso", "scipy"] | None = Field(
        None, description="Symmetric solver backend of every session (default: TETMORPH_SOLVER, else auto).")
    solve_reference: bool = Field(False, description="Build every session on the plain reference path: the "
                                  "backends' own solves, no supernodal sweeps, no column basis.")
    solver_threads: int = Field(0, ge=0, description="Most threads one solve uses (0: every free core; 1: "
                                "serial solves, for hosts that run other work on every core).")
    spec_solve_options: list[Literal["backend", "precision", "threads", "sweeps", "basis"]] = Field(
        ["precision", "threads"], description="The fields of a SPEC's solve_options a client may set (a JSON "
        "list); a SPEC that sets another is refused (422 solve_option_not_allowed), so that the backend and "
        "the solve path stay the operator's (solve_backend, solve_reference). threads only lowers "
        "solver_threads.")
    demo: bool = Field(False, description="Load the demo beam and session at start-up.")
    load_kernels: bool = Field(True, description="Load the solver's compiled kernels at start-up, before "
                               "/ready answers ready, so that no client's first session waits for them.")
    sweep_interval_s: float = Field(60.0, gt=0, description="How often idle sessions are swept.")
    expired_memory_s: float = Field(7 * 24 * 3600.0, ge=0,
                                    description="How long a swept session answers 410 session_expired "
                                                "(then 404).")
    max_frame_kb: float = Field(1024.0, gt=0, description="Largest WebSocket frame (close 1009 above).")
    max_connections_per_key: int = Field(16, gt=0,
                                         description="Open WebSocket streams per API key (4429 above).")
    parse_workers: int = Field(2, gt=0, description="Processes that read uploaded files (meshes, target "
                               "surfaces, stored meshes read back); the server process never parses one. One "
                               "API key uses at most all but one of them at once.")
    parse_time_limit_s: float = Field(120.0, gt=0, description="Longest one file may take to be read; its "
                                      "worker is then killed and replaced (422 parse_time_limit).")
    parse_cpu_limit_s: float = Field(120.0, gt=0, description="Most CPU seconds one file's read may use "
                                     "(RLIMIT_CPU of the worker; 422 parse_cpu_limit).")
    parse_memory_mb: float = Field(0.0, ge=0, description="Address space a parse worker may add to what it "
                                   "uses once started (RLIMIT_AS; 413 parse_memory_limit). 0: derived, three "
                                   "times max_file_expanded_mb plus max_upload_mb (readers hold a "
                                   "compressed array, its blocks and the array at once).")
    parse_queue_depth: int = Field(8, gt=0, description="Files one API key may have waiting to be read "
                                   "(429 parse_queue_full above).")
    tetra_workers: int = Field(1, gt=0, description="Processes that run fTetWild (one job each).")
    tetra_time_limit_s: float = Field(600.0, gt=0,
                                      description="A tetrahedralization running longer is stopped (422).")
    tetra_max_triangles: int = Field(2_000_000, gt=0,
                                     description="Largest surface POST /v1/tetrahedralize accepts (422 above).")
    job_wait_s: float = Field(5.0, ge=0,
                              description="How long POST /v1/tetrahedralize waits before answering 202.")
    log_json: bool = Field(False, description="Write logs as one JSON object per line.")
    database_url: str | None = Field(None, description="postgresql://... : keep mesh and session records in "
                                     "PostgreSQL, shared by replicas (default: the data directory alone).")
    replica_id: str = Field(default_factory=lambda: f"{socket.gethostname()}-{os.getpid()}", max_length=64,
                            description="This replica's name, sent as X-Tetmorph-Replica on every answer.")
    ray_address: str | None = Field(None, description="Ray cluster address (ray://host:10001, auto, or "
                                    "host:6379): POST /v1/sessions/{id}/batch accepts engine 'ray'.")
    ray_actors: int = Field(2, gt=0, description="Ray actors per batch (each holds one factorization).")
    batch_max_rows: int = Field(10_000, gt=0, description="Most plan rows per batch (422 above).")
    batch_max_result_mb: float = Field(1024.0, gt=0,
                                       description="Largest zip a batch may produce (the job fails above).")
    batch_time_limit_s: float = Field(3600.0, gt=0, description="A batch running longer is stopped.")
    batch_workers: int = Field(1, gt=0, description="Batches solved at once per replica (more queue).")
    study_solvers: dict[str, str] = Field(default_factory=dict, description="FE solver commands a study "
                                          "may run, by name (JSON, e.g. {\"ccx\": \"ccx -i {stem}\"}; "
                                          "{stem}, {deck}, {dir}, {i} substituted). A study names one; clients "
                                          "never send a command. Empty: POST /v1/sessions/{id}/study answers "
                                          "422 solver_unavailable.")
    study_timeout_s: float = Field(600.0, gt=0, description="Longest a study's solver run may take; a study "
                                   "may ask for less.")
    bounds_time_limit_s: float = Field(30.0, gt=0,
                                       description="POST /v1/sessions/{id}/bounds stops after this (422).")

    def solve_options(self) -> SolveOptions:
        """The :class:`~solver.options.SolveOptions` every session is built with."""
        base = solver_options.current()
        backend = self.solve_backend or base.backend
        return SolveOptions.reference(backend) if self.solve_reference else replace(base, backend=backend)

    @field_validator("api_keys", "allowed_origins", mode="before")
    @classmethod
    def _split_keys(cls, v: Any) -> Any:
        if isinstance(v, str):
            return [k.strip() for k in v.split(",") if k.strip()]
        return v

    @property
    def solve_pool_size(self) -> int:
        """Threads of the solve pool: :attr:`solve_workers`, or the cores this process may run on."""
        return self.solve_workers or len(os.sched_getaffinity(0))

    @property
    def max_upload_bytes(self) -> int:
        """Upload limit in bytes."""
        return int(self.max_upload_mb * 1024 * 1024)

    def read_bounds(self) -> ReadBounds:
        """What an uploaded mesh or surface file may declare or expand to, with the settings' names."""
        return ReadBounds(self.max_file_points, self.max_file_cells, int(self.max_file_expanded_mb * 2**20),
                          "TETMORPH_MAX_FILE_POINTS", "TETMORPH_MAX_FILE_CELLS", "TETMORPH_MAX_FILE_EXPANDED_MB")

    @property
    def parse_memory_bytes(self) -> int:
        """The address space a parse worker may add (``parse_memory_mb``, or derived from the upload bounds)."""
        mb = self.parse_memory_mb or 3 * self.max_file_expanded_mb + self.max_upload_mb
        return int(mb * 2**20)

    @property
    def max_header_bytes(self) -> int:
        """Request head limit in bytes."""
        return int(self.max_header_kb * 1024)

    @property
    def max_frame_bytes(self) -> int:
        """WebSocket frame limit in bytes."""
        return int(self.max_frame_kb * 1024)

    @property
    def batch_max_result_bytes(self) -> int:
        """Largest batch result in bytes."""
        return int(self.batch_max_result_mb * 1024 * 1024)

    @property
    def min_free_bytes(self) -> int:
        """Free space kept in reserve in the data directory, in bytes."""
        return int(self.min_free_mb * 2**20)

    @property
    def cache_budget_bytes(self) -> int:
        """Factorization cache budget in bytes."""
        return int(self.cache_budget_mb * 1024 * 1024)
