"""One deformation session and its status."""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from solver.deform.deformer import Deformer

from ..models.session import SessionStatus

__all__ = ["Session", "SessionStatus"]


@dataclass(eq=False)
class Session:
    """One deformation session: a mesh, a SPEC, and the latest committed MOVE."""

    id: str
    owner: str
    mesh_id: str
    spec: dict[str, Any]
    created: float
    last_move: dict[str, Any] | None = None
    last_used: float = field(default_factory=time.time)
    status: SessionStatus = SessionStatus.stored
    stage: str = ""
    progress: float = 0.0
    error: dict[str, Any] | None = None
    deformer: Deformer | None = None
    positions: np.ndarray | None = None
    report: dict[str, Any] | None = None
    updates: int = 0
    builds: int = 0
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)
    build_task: asyncio.Task[Deformer] | None = None
    checked: asyncio.Event = field(default_factory=asyncio.Event)
    #: Committed MOVEs of the record (optimistic concurrency between replicas).
    version: int = 0
    #: The SPEC with stored target surfaces resolved to vertices and triangles (not persisted).
    resolved: dict[str, Any] | None = None
    #: Batches running on this session (it is busy meanwhile).
    batches: int = 0
    #: Named MOVEs kept with the session (``[{"name", "move"}]``): stored apart from the record, no version.
    presets: list[dict[str, Any]] = field(default_factory=list)

    @classmethod
    def from_record(cls, rec: dict[str, Any]) -> Session:
        """A session as read back from its record (see :meth:`record`)."""
        now = time.time()
        s = cls(id=rec["id"], owner=rec["owner"], mesh_id=rec["mesh_id"], spec=rec["spec"],
                created=rec.get("created", now), last_move=rec.get("last_move"),
                last_used=rec.get("last_used", now), version=int(rec.get("version", 0)),
                presets=list(rec.get("presets") or []))
        if rec.get("failed"):
            s.status, s.error = SessionStatus.failed, rec["failed"]
        s.checked.set()
        return s

    def record(self) -> dict[str, Any]:
        """What persists across restarts (the presets apart: see ``Store.save_presets``)."""
        return {"id": self.id, "owner": self.owner, "mesh_id": self.mesh_id, "spec": self.spec,
                "created": self.created, "last_move": self.last_move, "last_used": self.last_used,
                "failed": self.error if self.status is SessionStatus.failed else None, "version": self.version}

    @property
    def busy(self) -> bool:
        """True while an update or a build runs."""
        return (self.lock.locked() or self.batches > 0
                or (self.build_task is not None and not self.build_task.done()))

    def doc(self, ttl_s: float | None = None) -> dict[str, Any]:
        """The public description (GET /v1/sessions/{id}); ``ttl_s`` gives ``expires_at``."""
        d = self.deformer
        return {
            "id": self.id, "mesh_id": self.mesh_id, "status": self.status.value, "stage": self.stage,
            "progress": round(self.progress, 3), "error": self.error, "created": self.created,
            "last_used": self.last_used,
            "expires_at": self.last_used + ttl_s if ttl_s is not None else None,
            "updates": self.updates, "builds": self.builds,
            "handles": list(d.handle_names) if d is not None else list(self.spec.get("handles", {})),
            "last_move": self.last_move, "version": self.version, "spec": self.spec,
            "setup_timings": d.setup_timings if d is not None else None,
            "factor_bytes": d.nbytes if d is not None else None,
            "constraints_at_rest": d.rest_constraints if d is not None else None,
            "edits_at_rest": d.edit_dimensions if d is not None else None,
            "last_report": self.report, "presets": self.presets,
        }
