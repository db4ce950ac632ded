"""In-memory state of the service over the persistent :class:`~service.store.Store`.

Meshes are read once and kept in a small LRU. A session owns a
:class:`~solver.deformer.Deformer` (its cached factorizations) while it is in
the factorization cache; the cache is bounded by a memory budget and evicts
the least recently used session, which is rebuilt transparently on its next
update. Updates to one session are serialized by its lock; assembly,
factorization and back-substitution run in worker threads, never on the event
loop.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from solver.constraints.spec import parse_spec
from solver.deform.deformer import Deformer, DeformResult
from solver.errors import InvalidMeshError, SolverError
from solver.mesh import Mesh

from .errors import NotFound, ServiceError
from .settings import Settings
from .store import Store, new_id, valid_id

__all__ = ["Registry", "Session"]

log = logging.getLogger("tetmorph.service")

#: How many parsed meshes stay in memory besides those held by sessions.
MESH_CACHE = 16


@dataclass(eq=False)
class Session:
    """One deformation session: a mesh, a SPEC, and the latest MOVE."""

    id: str
    owner: str
    mesh_id: str
    spec: dict[str, Any]
    created: float
    last_move: dict[str, Any] | None = None
    last_used: float = field(default_factory=time.time)
    status: str = "stored"  # stored | building | ready | evicted | failed
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

    def record(self) -> dict[str, Any]:
        """What persists across restarts."""
        return {"id": self.id, "owner": self.owner, "mesh_id": self.mesh_id, "spec": self.spec,
                "created": self.created, "last_move": self.last_move, "last_used": self.last_used,
                "failed": self.error if self.status == "failed" else None}

    def doc(self) -> dict[str, Any]:
        """The public description (GET /v1/sessions/{id})."""
        d = self.deformer
        return {
            "id": self.id, "mesh_id": self.mesh_id, "status": self.status, "stage": self.stage,
            "progress": round(self.progress, 3), "error": self.error, "created": self.created,
            "last_used": self.last_used, "updates": self.updates, "builds": self.builds,
            "handles": list(d.handle_names) if d is not None else list(self.spec.get("handles", {})),
            "last_move": self.last_move, "spec": self.spec,
            "setup_timings": d.setup_timings if d is not None else None,
            "factor_bytes": d.nbytes if d is not None else None,
            "constraints_at_rest": d.rest_constraints if d is not None else None,
            "last_report": self.report,
        }


class Registry:
    """Meshes and sessions of one service instance.

    Parameters
    ----------
    settings : Settings
    """

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.store = Store(settings.data_dir)
        self.sessions: dict[str, Session] = {}
        self._meshes: OrderedDict[str, Mesh] = OrderedDict()
        self._cache: OrderedDict[str, int] = OrderedDict()  # ready session id -> bytes (LRU)
        self.evictions = 0
        self.start()
        for rec in self.store.list_sessions():
            s = Session(id=rec["id"], owner=rec["owner"], mesh_id=rec["mesh_id"], spec=rec["spec"],
                        created=rec.get("created", time.time()), last_move=rec.get("last_move"),
                        last_used=rec.get("last_used", time.time()))
            if rec.get("failed"):
                s.status, s.error = "failed", rec["failed"]
            s.checked.set()
            self.sessions[s.id] = s

    def start(self) -> None:
        """Start the worker threads (again, after :meth:`close`)."""
        self.build_pool = ThreadPoolExecutor(self.settings.build_workers,
                                             thread_name_prefix="tm-build")
        self.solve_pool = ThreadPoolExecutor(self.settings.solve_workers,
                                             thread_name_prefix="tm-solve")
        self._closed = False

    def close(self) -> None:
        """Stop the worker threads."""
        self._closed = True
        self.build_pool.shutdown(wait=False, cancel_futures=True)
        self.solve_pool.shutdown(wait=False, cancel_futures=True)

    async def run(self, fn: Any, *args: Any) -> Any:
        """Run a blocking call (file export, tetrahedralization) in a worker thread."""
        return await asyncio.get_running_loop().run_in_executor(self.build_pool, fn, *args)

    # ----------------------------------------------------------------- meshes
    def mesh_meta(self, owner: str, mesh_id: str) -> dict[str, Any]:
        """Meta of a mesh owned by ``owner``; 404 otherwise."""
        meta = self.store.mesh_meta(mesh_id)
        if meta is None or meta.get("owner") != owner:
            raise NotFound("mesh", mesh_id)
        return meta

    def list_meshes(self, owner: str) -> list[dict[str, Any]]:
        """Metas of the meshes of ``owner``."""
        return [m for m in self.store.list_meshes() if m.get("owner") == owner]

    async def mesh(self, meta: dict[str, Any]) -> Mesh:
        """The parsed mesh of a stored meta (read in a worker thread on a miss)."""
        mid = meta["id"]
        m = self._meshes.get(mid)
        if m is None:
            loop = asyncio.get_running_loop()
            m = await loop.run_in_executor(self.solve_pool, self.store.load_mesh, meta)
            self._meshes[mid] = m
            while len(self._meshes) > MESH_CACHE:
                self._meshes.popitem(last=False)
        self._meshes.move_to_end(mid)
        return m

    def _check_size(self, mesh: Mesh) -> None:
        m = mesh.elements
        if m > self.settings.max_elements:
            raise ServiceError(422, f"the mesh has {m} volume elements; this service accepts at most "
                               f"{self.settings.max_elements}", code="too_many_elements",
                               elements=m, limit=self.settings.max_elements)

    async def add_mesh(self, owner: str, name: str, fmt: str, files: dict[str, bytes],
                       main: str, mesh_id: str | None = None) -> dict[str, Any]:
        """Store uploaded file(s) and parse them.

        Parameters
        ----------
        owner, name : str
        fmt : str
            meshio format name.
        files : dict of str to bytes
            File name (sanitized) to content; ``main`` is the one to read
            (TetGen's ``.node`` next to its ``.ele``).
        main : str
        mesh_id : str, optional
            A fixed id (the demo); random by default.

        Returns
        -------
        dict
            The mesh document (id, counts, element types, sets, quality).
        """
        mid = mesh_id or new_id("m")
        meta = {"id": mid, "owner": owner, "name": name, "format": fmt, "file": main,
                "files": sorted(files), "created": time.time()}

        async def write_and_read(d: Path) -> Mesh:
            for fname, data in files.items():
                (d / fname).write_bytes(data)
            loop = asyncio.get_running_loop()
            return await loop.run_in_executor(self.build_pool, self.store.load_mesh, meta)

        return await self._store_mesh(meta, write_and_read)

    async def add_mesh_arrays(self, owner: str, name: str, mesh: Mesh,
                              extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Store a mesh built from arrays (JSON upload, tetrahedralization)."""
        self._check_size(mesh)  # before anything is written
        meta = {"id": new_id("m"), "owner": owner, "name": name, "format": "arrays",
                "file": "arrays.npz", "files": ["arrays.npz"], "created": time.time(),
                **(extra or {})}

        async def write(d: Path) -> Mesh:
            self.store.save_arrays(meta["id"], mesh)
            return mesh

        return await self._store_mesh(meta, write)

    async def _store_mesh(self, meta: dict[str, Any],
                          produce: Callable[[Path], Awaitable[Mesh]]) -> dict[str, Any]:
        """Create the mesh's directory, let ``produce`` fill it and return the parsed mesh,
        then check its size and save ``meta`` with its summary; remove everything on failure."""
        mid = meta["id"]
        d = self.store.new_mesh_dir(mid)
        try:
            mesh = await produce(d)
            self._check_size(mesh)
            loop = asyncio.get_running_loop()
            meta["info"] = await loop.run_in_executor(self.solve_pool, mesh.info)
            self.store.save_mesh_meta(meta)
        except BaseException:
            self.store.delete_mesh(mid)
            raise
        self._meshes[mid] = mesh
        return meta

    def delete_mesh(self, owner: str, mesh_id: str) -> None:
        """Delete a mesh; 409 while sessions use it."""
        self.mesh_meta(owner, mesh_id)
        users = sorted(s.id for s in self.sessions.values() if s.mesh_id == mesh_id)
        if users:
            raise ServiceError(409, f"mesh {mesh_id} is used by sessions {users}; delete them first",
                               code="mesh_in_use", sessions=users)
        self._meshes.pop(mesh_id, None)
        self.store.delete_mesh(mesh_id)

    def mesh_file(self, meta: dict[str, Any]) -> Path:
        """Path of the stored main file."""
        return self.store.mesh_dir(meta["id"]) / meta["file"]

    # --------------------------------------------------------------- sessions
    def session(self, owner: str, session_id: str) -> Session:
        """A session of ``owner``; 404 otherwise (also for other keys' sessions)."""
        s = self.sessions.get(session_id) if valid_id(session_id) else None
        if s is None or s.owner != owner:
            raise NotFound("session", session_id)
        return s

    def list_sessions(self, owner: str) -> list[Session]:
        """Sessions of ``owner``, oldest first."""
        return sorted((s for s in self.sessions.values() if s.owner == owner),
                      key=lambda s: s.created)

    async def create_session(self, owner: str, mesh_id: str, spec: dict[str, Any],
                             session_id: str | None = None) -> Session:
        """Create a session and start its build.

        Waits until every SPEC error has surfaced (selections resolved and
        checked), then up to ``build_wait_s`` for the factorization. The
        returned session's ``status`` is ``"ready"`` or ``"building"``.

        Raises
        ------
        SpecError, ConstraintError, InvalidMeshError
            The SPEC does not fit the mesh; nothing is stored.
        ServiceError
            404 unknown mesh, 429 too many sessions.
        """
        self.sweep()
        meta = self.mesh_meta(owner, mesh_id)
        parse_spec(spec)  # malformed SPEC: 422 before anything is stored
        mine = sum(1 for s in self.sessions.values() if s.owner == owner)
        if mine >= self.settings.max_sessions:
            raise ServiceError(429, f"this key already has {mine} sessions (limit "
                               f"{self.settings.max_sessions}); delete one first",
                               code="session_limit", sessions=mine,
                               limit=self.settings.max_sessions)
        sid = session_id or new_id("s")
        if sid in self.sessions:
            raise ServiceError(409, f"session {sid} exists", code="session_exists")
        s = Session(id=sid, owner=owner, mesh_id=meta["id"], spec=spec, created=time.time())
        self.sessions[sid] = s
        task = self._start_build(s)
        checked = asyncio.ensure_future(s.checked.wait())
        try:
            await asyncio.wait({task, checked}, return_when=asyncio.FIRST_COMPLETED)
            if task.done() and task.exception() is not None:
                raise task.exception()  # type: ignore[misc]
            self.store.save_session(s.record())
            try:
                await asyncio.wait_for(asyncio.shield(task), self.settings.build_wait_s)
            except TimeoutError:
                pass  # answered 202; the build goes on
        except BaseException:
            checked.cancel()
            self.sessions.pop(sid, None)
            self.store.delete_session(sid)
            raise
        return s

    def _start_build(self, s: Session) -> asyncio.Task[Deformer]:
        if s.build_task is None or s.build_task.done():
            s.build_task = asyncio.ensure_future(self._build(s))
            # a failed background build is recorded on the session; never "never retrieved"
            s.build_task.add_done_callback(lambda t: t.cancelled() or t.exception())
        return s.build_task

    async def _build(self, s: Session) -> Deformer:
        loop = asyncio.get_running_loop()
        s.status, s.stage, s.progress, s.error = "building", "mesh", 0.0, None

        def progress(stage: str, fraction: float) -> None:
            s.stage, s.progress = stage, fraction
            if stage == "constraints":
                loop.call_soon_threadsafe(s.checked.set)

        try:
            mesh = await self.session_mesh(s)
            d = await loop.run_in_executor(self.build_pool, Deformer, mesh, s.spec, progress)
            if s.last_move is not None and s.positions is None:
                r = await loop.run_in_executor(self.solve_pool, d.solve, s.last_move, "warn")
                s.positions, s.report = r.V, _small(r.report)
        except SolverError as e:
            s.status, s.error = "failed", e.to_dict()
            s.checked.set()
            if s.id in self.sessions and self.store.mesh_meta(s.mesh_id) is not None:
                self.store.save_session(s.record())
            raise
        except BaseException as e:
            s.status = "failed"
            s.error = {"type": type(e).__name__, "code": "build_failed", "message": str(e),
                       "details": {}}
            s.checked.set()
            raise
        s.deformer, s.status, s.stage, s.progress = d, "ready", "done", 1.0
        s.builds += 1
        self._cache[s.id] = d.nbytes
        self._cache.move_to_end(s.id)
        self._enforce_budget(keep=s.id)
        return d

    async def session_mesh(self, s: Session) -> Mesh:
        """The parsed rest mesh of a session (from its deformer or the cache when there).

        Raises
        ------
        InvalidMeshError
            The mesh was removed from the data directory behind the service's back.
        """
        if s.deformer is not None:
            return s.deformer.mesh
        if s.mesh_id in self._meshes:
            self._meshes.move_to_end(s.mesh_id)
            return self._meshes[s.mesh_id]
        meta = self.store.mesh_meta(s.mesh_id)
        if meta is None:
            raise InvalidMeshError(f"the session's mesh {s.mesh_id} no longer exists",
                                   code="mesh_missing")
        return await self.mesh(meta)

    def _enforce_budget(self, keep: str) -> None:
        budget = self.settings.cache_budget_bytes
        total = sum(self._cache.values())
        for sid in list(self._cache):
            if total <= budget:
                break
            s = self.sessions.get(sid)
            if sid == keep or (s is not None and s.lock.locked()):
                continue
            total -= self._cache.pop(sid)
            if s is not None:
                s.deformer, s.status = None, "evicted"
                self.evictions += 1
                log.info("evicted session %s from the factorization cache", sid)

    @property
    def cached_sessions(self) -> int:
        """Sessions whose factorizations are in the cache."""
        return len(self._cache)

    @property
    def cache_bytes(self) -> int:
        """Bytes held by cached factorizations."""
        return sum(self._cache.values())

    async def deformer(self, s: Session) -> Deformer:
        """The session's deformer, rebuilding it if evicted or never built here."""
        d = s.deformer
        if d is not None:
            self._cache.move_to_end(s.id)
            return d
        if s.status == "failed" and s.build_task is None:
            raise ServiceError(422, f"session {s.id} failed to build: "
                               f"{(s.error or {}).get('message', '')}",
                               code=(s.error or {}).get("code", "build_failed"), error=s.error)
        return await self._start_build(s)

    async def deform(self, s: Session, move: dict[str, Any], inversion: str | None = None,
                     quality: str = "basic", repair: bool | None = None) -> DeformResult:
        """Solve one MOVE (serialized per session) and make it the session's state.

        Raises
        ------
        SpecError
            Malformed MOVE.
        InversionError
            ``reject`` policy and an inverting move; the session is unchanged.
        """
        async with s.lock:
            d = await self.deformer(s)
            mv = d.parse_move(move)
            loop = asyncio.get_running_loop()
            r = await loop.run_in_executor(self.solve_pool, d.solve, mv, inversion, quality, repair)
            if not r.report["finite"]:
                raise ServiceError(422, "the solve produced non-finite positions; the session is "
                                   "unchanged", code="non_finite_result", report=r.report)
            # a clamped MOVE is stored as applied, so a rebuild reproduces these positions
            applied = r.move.to_dict() if r.report.get("clamped") and r.move is not None else move
            s.positions, s.report, s.last_move = r.V, _small(r.report), applied
            s.updates += 1
            s.last_used = time.time()
            self.store.save_session(s.record())
            return r

    async def positions(self, s: Session) -> np.ndarray:
        """Current deformed positions (rest positions before the first MOVE)."""
        async with s.lock:
            if s.positions is None:
                if s.last_move is not None:
                    await self.deformer(s)  # restores positions from the last MOVE
                if s.positions is None:
                    return (await self.session_mesh(s)).V
            s.last_used = time.time()
            return s.positions

    async def reset(self, s: Session) -> None:
        """Back to the rest shape; the last MOVE is forgotten."""
        async with s.lock:
            s.positions, s.report, s.last_move = None, None, None
            s.last_used = time.time()
            self.store.save_session(s.record())

    async def delete_session(self, s: Session) -> None:
        """Remove a session from memory and disk (waits for a running update)."""
        async with s.lock:
            self.sessions.pop(s.id, None)
            self._cache.pop(s.id, None)
            s.deformer = None
            if s.build_task is not None and not s.build_task.done():
                s.build_task.cancel()
            self.store.delete_session(s.id)

    def sweep(self, now: float | None = None) -> list[str]:
        """Remove sessions idle longer than the TTL; return their ids."""
        now = time.time() if now is None else now
        gone = [s for s in self.sessions.values()
                if now - s.last_used > self.settings.session_ttl_s and not s.lock.locked()
                and (s.build_task is None or s.build_task.done())]
        for s in gone:
            self.sessions.pop(s.id, None)
            self._cache.pop(s.id, None)
            s.deformer = None
            self.store.delete_session(s.id)
            log.info("removed idle session %s", s.id)
        return [s.id for s in gone]


def _small(report: dict[str, Any]) -> dict[str, Any]:
    """The REPORT without its set-up timings (kept once per session)."""
    out = dict(report)
    t = out.get("timings")
    if isinstance(t, dict):
        out["timings"] = {"update": t.get("update")}
    return out
