"""The path of a MOVE: solved against its session's deformer, checked, and committed.

:class:`MovePath` is the one way a MOVE becomes a session's state. Updates to
one session are serialized by its lock. A MOVE, validated once by its model
(the request's, or here for a plain document), is checked by the library
against the session's SPEC and mesh, solved in the builder's threads, and becomes the
session's state (store first, then memory) only after every number of its
result is finite. With a shared store a MOVE commits only if the version it
was solved from is still the stored one; otherwise the session is reloaded
and the MOVE answers 409 ``version_conflict``, which the client retries.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from solver.deform.deformer import Deformer, DeformResult
from solver.documents.move import Move
from solver.documents.validation import validated

from ..errors import NotFound, ServiceError
from .builder import Builder, small_report
from .session import Session
from .sessions import Sessions
from .store import Store

__all__ = ["MovePath", "all_finite"]


def all_finite(doc: Any) -> bool:
    """True if every number in a JSON-like document is finite.

    Examples
    --------
    >>> all_finite({"a": [1, 2.5, {"b": None}]}), all_finite({"a": [float("inf")]})
    (True, False)
    """
    if isinstance(doc, float):
        return math.isfinite(doc)
    if isinstance(doc, dict):
        return all(all_finite(v) for v in doc.values())
    if isinstance(doc, (list, tuple)):
        return all(all_finite(v) for v in doc)
    return True


class MovePath:
    """Solve and commit the MOVEs of the sessions in ``sessions``.

    Parameters
    ----------
    sessions : Sessions
        Where each session's deformer and rest mesh come from.
    store : Store
    builder : Builder
        Whose threads solve.
    """

    def __init__(self, sessions: Sessions, store: Store, builder: Builder) -> None:
        self.sessions = sessions
        self.store = store
        self.builder = builder
        #: Called with the seconds of every solved MOVE (the metrics set it).
        self.observe_solve: Callable[[float], None] = lambda seconds: None

    async def deform(self, s: Session, move: Move | dict[str, Any], inversion: str | None = None,
                     quality: str = "basic", repair: bool | None = None) -> DeformResult:
        """Solve one MOVE (serialized per session) and make it the session's state.

        The MOVE is committed (memory and disk) only after it solved and every
        number of its positions and REPORT is finite; otherwise the session is
        left exactly as it was.

        Raises
        ------
        SpecError
            Malformed MOVE.
        InversionError
            ``reject`` policy and an inverting move; the session is unchanged.
        ServiceError
            ``non_finite_result``: the solve produced non-finite numbers.
        """
        async with s.lock:
            d = await self.sessions.deformer(s)
            doc = validated(Move, move, "MOVE")
            mv = d.parse_move(doc)
            t0 = time.perf_counter()
            r = await self.builder.solve(d.solve, mv, inversion, quality, repair)
            self.observe_solve(time.perf_counter() - t0)
            return self._commit(s, r, doc.dump())

    async def boundary_stage(self, s: Session, move: Move | dict[str, Any]) -> tuple[Deformer, Any, dict[str, Any]]:
        """The boundary positions of a MOVE first (nothing is committed): ``(deformer, stage, move)``.

        Pass them to :meth:`complete_stage` for the interior, the check and the commit.
        """
        async with s.lock:
            d = await self.sessions.deformer(s)
            doc = validated(Move, move, "MOVE")
            mv = d.parse_move(doc)
            stage = await self.builder.solve(d.solve_boundary, mv)
            return d, stage, doc.dump()

    async def complete_stage(self, s: Session, d: Deformer, stage: Any, move: dict[str, Any],
                             inversion: str | None = None, repair: bool | None = None) -> DeformResult:
        """Finish a :meth:`boundary_stage` solve and commit it like :meth:`deform`."""
        async with s.lock:
            if s.deformer is not d:  # rebuilt or evicted in between: solve afresh
                d = await self.sessions.deformer(s)
                stage = d.parse_move(move)
            t0 = time.perf_counter()
            r = await self.builder.solve(d.solve, stage, inversion, "basic", repair)
            self.observe_solve(time.perf_counter() - t0)
            return self._commit(s, r, move)

    def _commit(self, s: Session, r: DeformResult, move: dict[str, Any]) -> DeformResult:
        """Make a solved MOVE the session's state, memory and disk, if every number is finite."""
        finite = bool(np.isfinite(r.V).all()) and all_finite(r.report)
        r.report["finite"] = finite
        if not finite:
            raise ServiceError("non_finite_result", "the solve produced non-finite numbers; the "
                               "session is unchanged", session_id=s.id)
        # a clamped MOVE is stored as applied, so a rebuild reproduces these positions
        applied = r.move.to_dict() if r.report.get("clamped") and r.move is not None else move
        rec = {**s.record(), "last_move": applied, "last_used": time.time()}
        self._store_commit(s, rec)  # the store first: a failed write leaves memory unchanged
        s.positions, s.report, s.last_move = r.V, small_report(r.report), applied
        s.updates += 1
        s.last_used = rec["last_used"]
        return r

    def _store_commit(self, s: Session, rec: dict[str, Any]) -> None:
        """Write a session's new record if its version is still ``s.version``; else reload and answer 409."""
        solved_from = s.version
        version = self.store.commit_session(rec, solved_from)
        if version is None:
            if not self.sessions.reload(s):
                self.sessions.drop_local(s)
                raise NotFound("session", s.id)
            raise ServiceError("version_conflict", f"session {s.id} changed while this request was solved "
                               f"(version {solved_from}, now {s.version}); nothing was committed: retry",
                               session_id=s.id, version=solved_from, current=s.version)
        s.version = version

    async def positions(self, s: Session) -> np.ndarray:
        """Current deformed positions (rest positions before the first MOVE)."""
        async with s.lock:
            if s.positions is None and s.last_move is not None:
                d = await self.sessions.deformer(s)  # a build restores positions from the last MOVE
                if s.positions is None:  # built before the record moved on (another replica's MOVE)
                    r = await self.builder.solve(d.solve, s.last_move, "warn")
                    s.positions, s.report = r.V, small_report(r.report)
            if s.positions is None:
                return (await self.sessions.mesh(s)).V
            return s.positions

    async def reset(self, s: Session) -> None:
        """Back to the rest shape; the last MOVE is forgotten."""
        async with s.lock:
            self._store_commit(s, {**s.record(), "last_move": None, "last_used": time.time()})
            s.positions, s.report, s.last_move = None, None, None
