"""The service's sessions: their lifecycle, and their copies across replicas.

:class:`Sessions` holds the sessions of one service instance, by id. It
creates a session (checking its SPEC against the mesh before anything is
stored), builds its :class:`~solver.deform.deformer.Deformer` in the
builder's threads, keeps the factorization cache's accounts, rebuilds an
evicted session on its next use, deletes, and sweeps idle sessions.

With a shared store (PostgreSQL, several replicas) a session's record is the
truth and this process holds a cache of it: every request on a session
records its use and reads the stored version; a newer version (a MOVE
committed by another replica) is loaded before the request is served.

What a client keeps with a session apart from its morph state (presets,
undo history) is in :mod:`~service.state.kept`.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Iterator, Mapping
from typing import Any

from solver.constraints.spec import parse_spec
from solver.deform.deformer import Deformer
from solver.errors import InvalidMeshError
from solver.mesh import Mesh

from ..errors import NotFound, ServiceError, error_from_dict
from ..models.spec import check_solve_options, check_spec_ids, stored_surfaces
from ..settings import Settings
from .builder import Builder
from .catalogue import Catalogue
from .factor_cache import FactorCache
from .memory import release_memory
from .session import Session, SessionStatus
from .store import Store, new_id, valid_id
from .surfaces import resolve_spec

__all__ = ["Sessions"]

log = logging.getLogger("tetmorph.service")


class Sessions(Mapping[str, Session]):
    """The sessions of one service instance, a read-only mapping of id to :class:`Session`.

    Parameters
    ----------
    settings : Settings
    store : Store
    builder : Builder
        Whose threads build the deformers.
    factors : FactorCache
        The accounts of the factorizations held in memory.
    catalogue : Catalogue
        The meshes the sessions are made on.
    """

    def __init__(self, settings: Settings, store: Store, builder: Builder, factors: FactorCache,
                 catalogue: Catalogue) -> None:
        self.settings = settings
        self.store = store
        self.builder = builder
        self.factors = factors
        self.catalogue = catalogue
        self._live: dict[str, Session] = {}
        #: Sessions removed for idleness: id -> (owner, when) (with a shared store: asked from it).
        self.expired: dict[str, tuple[str, float]] = {}
        if not self.store.shared:  # a shared store's sessions are loaded when first asked for
            self._live = {s.id: s for s in map(Session.from_record, self.store.list_sessions())}
            self.expired = {r["id"]: (r["owner"], r["expired_at"]) for r in self.store.list_expired()}

    def __getitem__(self, session_id: str) -> Session:
        return self._live[session_id]

    def __iter__(self) -> Iterator[str]:
        return iter(self._live)

    def __len__(self) -> int:
        return len(self._live)

    def users_of_mesh(self, mesh_id: str) -> list[str]:
        """Ids of the sessions made on a mesh or naming it as a stored target surface."""
        if self.store.shared:
            return self.store.sessions_of_mesh(mesh_id)
        return sorted(s.id for s in self._live.values()
                      if s.mesh_id == mesh_id or any(m == mesh_id for _, m in stored_surfaces(s.spec)))

    def lookup(self, owner: str, session_id: str) -> Session:
        """A session of ``owner``; 404 otherwise (also for other keys' sessions), 410 when expired.

        With a shared store this records the use and loads the record when it
        is newer than this process's copy (or not here at all).
        """
        s = self._live.get(session_id) if valid_id(session_id) else None
        if self.store.shared and valid_id(session_id):
            s = self._sync(session_id, s)
        if s is None or s.owner != owner:
            gone = self.expired.get(session_id) if not self.store.shared else self.store.expired(session_id)
            if gone is not None and gone[0] == owner:
                raise ServiceError("session_expired", f"session {session_id} was removed after "
                                   f"{self.settings.session_ttl_s:g} s without use", session_id=session_id,
                                   expired_at=gone[1], ttl_s=self.settings.session_ttl_s)
            raise NotFound("session", session_id)
        return s

    def _sync(self, session_id: str, s: Session | None) -> Session | None:
        """The local copy of a shared session, current with its record (None when it is gone)."""
        now = time.time()
        version = self.store.touch_session(session_id, now)
        if version is None:
            if s is not None and not s.busy:
                self.drop_local(s)
            return None
        if s is None:
            rec = self.store.load_session(session_id)
            if rec is None:
                return None
            s = Session.from_record(rec)
            self._live[s.id] = s
        elif version != s.version and not s.lock.locked():
            self.reload(s)
        s.last_used = max(s.last_used, now)
        return s

    def reload(self, s: Session) -> bool:
        """Load a session's record into this process's copy; False when the record is gone."""
        rec = self.store.load_session(s.id)
        if rec is None:
            return False
        if rec.get("version", 0) != s.version or rec.get("last_move") != s.last_move:
            s.positions, s.report = None, None  # recomputed from the record's MOVE when asked for
        s.version, s.last_move = int(rec.get("version", 0)), rec.get("last_move")
        s.last_used = max(s.last_used, float(rec.get("last_used", s.last_used)))
        s.presets = list(rec.get("presets") or [])
        return True

    def drop_local(self, s: Session) -> None:
        """Forget this process's copy of a session (its record is gone or moved on)."""
        self._live.pop(s.id, None)
        self.factors.drop(s.id)
        s.deformer, s.positions = None, None
        if s.build_task is not None and not s.build_task.done():
            s.build_task.cancel()
        s.build_task = None

    def owned(self, owner: str) -> list[Session]:
        """Sessions of ``owner``, oldest first."""
        if self.store.shared:
            out = []
            for rec in self.store.list_sessions():
                if rec.get("owner") != owner:
                    continue
                s = self._live.get(rec["id"])
                if s is None:
                    s = self._live[rec["id"]] = Session.from_record(rec)
                elif rec.get("version", 0) != s.version and not s.lock.locked():
                    self.reload(s)
                s.presets = list(rec.get("presets") or [])
                out.append(s)
            return sorted(out, key=lambda s: s.created)
        return sorted((s for s in self._live.values() if s.owner == owner),
                      key=lambda s: s.created)

    async def spec(self, s: Session) -> dict[str, Any]:
        """The SPEC a session builds from (stored target surfaces resolved, once per process)."""
        if s.resolved is None:
            s.resolved = await resolve_spec(self.catalogue, s.owner, s.spec)
        return s.resolved

    async def create(self, owner: str, mesh_id: str, spec: dict[str, Any],
                             session_id: str | None = None) -> Session:
        """Create a session and start its build.

        Waits until every SPEC error has surfaced (selections resolved and
        checked), then up to ``build_wait_s`` for the factorization. The
        returned session's ``status`` is ``ready`` or ``building``.

        Raises
        ------
        SpecError, ConstraintError, InvalidMeshError
            The SPEC does not fit the mesh; nothing is stored.
        ServiceError
            404 unknown mesh, 429 too many sessions, 422 an unknown target surface.
        """
        self.sweep()
        meta = self.catalogue.meta(owner, mesh_id)
        check_spec_ids(spec, int(meta.get("info", {}).get("vertices", 0)))
        check_solve_options(spec, self.settings.spec_solve_options)
        resolved = await resolve_spec(self.catalogue, owner, spec)
        parse_spec(resolved)  # malformed SPEC: 422 before anything is stored
        limit = self.settings.max_sessions
        mine = (self.store.count_sessions(owner) if self.store.shared else
                sum(1 for s in self._live.values() if s.owner == owner))
        if mine >= limit:
            raise ServiceError("session_limit", f"this key already has {mine} sessions (limit "
                               f"{limit}); delete one first", sessions=mine, limit=limit)
        sid = session_id or new_id("s")
        if sid in self._live:
            raise ServiceError("session_exists", f"session {sid} exists", session_id=sid)
        s = Session(id=sid, owner=owner, mesh_id=meta["id"], spec=spec, created=time.time())
        s.resolved = resolved
        self._live[sid] = s
        task = self._start_build(s)
        checked = asyncio.ensure_future(s.checked.wait())
        stored = False
        try:
            await asyncio.wait({task, checked}, return_when=asyncio.FIRST_COMPLETED)
            if task.done() and task.exception() is not None:
                raise task.exception()  # type: ignore[misc]
            self.store.create_session(s.record(), limit)  # atomic count and insert when shared
            stored = True
            try:
                await asyncio.wait_for(asyncio.shield(task), self.settings.build_wait_s)
            except TimeoutError:
                pass  # answered 202; the build goes on
        except BaseException:
            checked.cancel()
            self._live.pop(sid, None)
            self.factors.drop(sid)  # built before its record failed to store (a full disk): not in the cache
            if stored:
                self.store.delete_session(sid)
            if not task.done():
                task.cancel()
            raise
        return s

    def _start_build(self, s: Session) -> asyncio.Task[Deformer]:
        return self.builder.start_build(s, self.mesh, self._built, self._failed, self.spec)

    def _built(self, s: Session, d: Deformer) -> None:
        self.factors.add(s.id, d.nbytes)
        def pinned(sid: str) -> bool:
            o = self._live.get(sid)
            return o is not None and o.busy

        for sid in self.factors.evict(keep=s.id, pinned=pinned):
            o = self._live.get(sid)
            if o is not None:
                o.deformer, o.status, o.build_task = None, SessionStatus.evicted, None
                log.info("evicted session %s from the factorization cache", sid)

    def _failed(self, s: Session) -> None:
        # only a session the store already holds records its failure, in one conditional write: a build
        # that fails while its POST is still being answered (a SPEC that does not fit the mesh) stores
        # nothing, and a session deleted meanwhile (here, or by another replica between any check and
        # the write) stays deleted
        if s.id in self._live:
            self.store.update_session(s.record(), s.version)

    async def mesh(self, s: Session) -> Mesh:
        """The parsed rest mesh of a session (from its deformer or the cache when there).

        Raises
        ------
        InvalidMeshError
            The mesh was removed from the data directory behind the service's back.
        """
        if s.deformer is not None:
            return s.deformer.mesh
        m = self.catalogue.cache.get(s.mesh_id)
        if m is not None:
            return m
        meta = self.store.mesh_meta(s.mesh_id)
        if meta is None:
            raise InvalidMeshError(f"the session's mesh {s.mesh_id} no longer exists",
                                   code="mesh_missing")
        return await self.catalogue.mesh(meta)

    async def deformer(self, s: Session) -> Deformer:
        """The session's deformer, rebuilding it if evicted or never built here."""
        d = s.deformer
        if d is not None:
            self.factors.touch(s.id)
            return d
        if s.status is SessionStatus.failed and s.build_task is None:
            raise error_from_dict(s.error or {"code": "build_failed"}, prefix=f"session {s.id} failed to build: ")
        return await self._start_build(s)

    async def delete(self, s: Session) -> None:
        """Remove a session from memory and disk (waits for a running update)."""
        async with s.lock:
            self.drop_local(s)
            self.store.delete_session(s.id)
        release_memory()

    def sweep(self, now: float | None = None) -> list[str]:
        """Remove sessions idle longer than the TTL; return their ids.

        With a shared store the records are swept in the database (one
        statement, so replicas sweeping at once remove each session once), and
        this process forgets its copies of sessions whose records are gone.
        """
        now = time.time() if now is None else now
        ttl = self.settings.session_ttl_s
        if self.store.shared:
            for s in self._live.values():
                if s.busy:
                    self.store.touch_session(s.id, now)
            ids = [sid for sid, _ in self.store.expire_idle(now - ttl)]
            alive = self.store.existing(list(self._live))
            for s in [s for s in self._live.values() if s.id not in alive and not s.busy]:
                self.drop_local(s)
            self.store.forget_expired(now - self.settings.expired_memory_s)
            if ids:
                log.info("removed %d idle sessions", len(ids))
                release_memory()
            return ids
        gone = [s for s in self._live.values() if now - s.last_used > ttl and not s.busy]
        for s in gone:
            self.drop_local(s)
            self.store.delete_session(s.id)
            self.expired[s.id] = (s.owner, now)
            self.store.save_expired(s.id, s.owner, now)
            log.info("removed idle session %s", s.id)
        for sid in [k for k, (_, at) in self.expired.items() if now - at > self.settings.expired_memory_s]:
            self.expired.pop(sid, None)
            self.store.delete_expired(sid)
        if gone:
            release_memory()
        return [s.id for s in gone]
